"""Entry module of the ``flow`` plugin: registers components lazily (no torch imported here)."""

from __future__ import annotations

from pathlib import Path

from dance_core import hookimpl
from dance_flow import configs as c

RECIPES = Path(__file__).resolve().parent / "recipes"


@hookimpl
def register_encoders(register):
    """Transflower's multimodal transformer encoder and MoGlow's concatenated-context LSTM."""
    register(
        "transflower",
        c.TransflowerEncoderConfig,
        "dance_flow.encoder:build",
        "motion + music transformers and a cross-modal transformer (relative positions)",
    )
    register(
        "moglow-context",
        c.MoGlowContextConfig,
        "dance_flow.moglow:build",
        "LSTM over concatenated recent motion and music frames (MoGlow)",
    )


@hookimpl
def register_heads(register):
    """The normalizing-flow output head."""
    register(
        "flow",
        c.FlowHeadConfig,
        "dance_flow.head:build",
        "Glow-style flow over N frames with transformer couplings; exact NLL, temperature",
    )


@hookimpl
def register_recipes(register):
    """Transflower, its two baselines, and the small recipe of the bundled model."""
    for name, description in (
        ("transflower", "Transflower at the paper's sizes (122 M parameters)"),
        ("aichoreographer", "AI Choreographer baseline: the same encoder, deterministic regression head"),
        ("moglow", "MoGlow baseline: concatenated-context LSTM + flow head"),
        ("transflower-small", "small Transflower that trains on 2 CPU cores in minutes; the bundled model"),
    ):
        register(name, None, str(RECIPES / f"{name}.yaml"), description)
    register(
        "default",
        None,
        str(RECIPES / "transflower-small.yaml"),
        "the bundled model: transflower-small with its trained weights (dance compose default)",
    )
