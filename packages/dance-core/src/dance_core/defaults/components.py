"""Core's model parts, energy features, schedules and recipes: the plain baseline every family is compared with."""

from __future__ import annotations

from pathlib import Path

from dance_core.components import configs as c
from dance_core.hookspecs import hookimpl

_M = "dance_core.components"
RECIPES = Path(__file__).resolve().parent.parent / "recipes"


@hookimpl
def register_conditioners(register):
    """Core's per-frame MLP conditioner."""
    register("mlp", c.MLPConditionerConfig, f"{_M}.modules:build_mlp_conditioner",
             "per-frame MLP over one feature stream")


@hookimpl
def register_encoders(register):
    """Core's windowed MLP encoder."""
    register("window-mlp", c.WindowMLPConfig, f"{_M}.modules:build_window_mlp",
             "MLP over a flattened window of past motion and conditioning")


@hookimpl
def register_heads(register):
    """Core's deterministic regression head (AI Choreographer's head)."""
    register("regression", c.RegressionHeadConfig, f"{_M}.modules:build_regression_head",
             "deterministic frames with an L1 or L2 loss")


@hookimpl
def register_feature_extractors(register):
    """Core's dependency-free audio features."""
    register("energy", c.EnergyConfig, f"{_M}.energy:build",
             "log band energies and spectral-flux onset strength (numpy only)")


@hookimpl
def register_schedules(register):
    """Core's learning-rate schedules."""
    register("constant", c.ConstantConfig, f"{_M}.schedules:build_constant", "a constant value")
    register("cosine", c.CosineConfig, f"{_M}.schedules:build_cosine",
             "linear warm-up, then cosine decay to a floor")
    register("multistep", c.MultiStepConfig, f"{_M}.schedules:build_multistep",
             "warm-up, then multiply by gamma at each milestone")


@hookimpl
def register_recipes(register):
    """Core's bundled recipes."""
    register("core-synthetic", None, str(RECIPES / "core-synthetic.yaml"),
             "window-mlp + regression head on synthetic beats; trains on CPU in seconds")
    register("core-dance", None, str(RECIPES / "core-dance.yaml"),
             "window-mlp + regression head on the synthetic dancer; writes BVH")
