"""Entry module of the ``rnn`` plugin: registers components lazily (no torch imported here)."""

from __future__ import annotations

from pathlib import Path

from dance_core import hookimpl
from dance_rnn import configs as c

_M = "dance_rnn"
RECIPES = Path(__file__).resolve().parent / "recipes"


@hookimpl
def register_encoders(register):
    """DanceRevolution's local self-attention music encoder."""
    register(
        "local-attention",
        c.LocalAttentionConfig,
        f"{_M}.encoder:build",
        "song-level transformer whose frames attend to their k nearest neighbours, O(n·k)",
    )


@hookimpl
def register_heads(register):
    """DanceRevolution's LSTM dance decoder."""
    register(
        "lstm-decoder",
        c.LSTMHeadConfig,
        f"{_M}.decoder:build",
        "stacked LSTM with h0 ~ N(0, I), L1 loss, dynamic auto-condition training",
    )


@hookimpl
def register_schedules(register):
    """The four growth functions of q (generated inputs per period) for dynamic auto-condition."""
    register(
        "auto-condition-const",
        c.ConstantCurriculumConfig,
        f"{_M}.curriculum:build_const",
        "q = value (static auto-condition)",
    )
    register(
        "auto-condition-linear",
        c.CurriculumConfig,
        f"{_M}.curriculum:build_linear",
        "q = floor(lambda t), t = epoch + offset",
    )
    register(
        "auto-condition-quadratic", c.CurriculumConfig, f"{_M}.curriculum:build_quadratic", "q = floor(lambda t^2)"
    )
    register(
        "auto-condition-exponential",
        c.ExponentialCurriculumConfig,
        f"{_M}.curriculum:build_exponential",
        "q = min(limit, floor(lambda e^t))",
    )


@hookimpl
def register_recipes(register):
    """DanceRevolution at the paper's sizes, two CPU-sized variants (the second for real moves,
    trained by the user: no weights ship), and a cross-breed with dance-flow."""
    register(
        "dancerevolution",
        None,
        str(RECIPES / "dancerevolution.yaml"),
        "DanceRevolution at the paper's sizes (local attention k=100, 3-layer LSTM, linear curriculum)",
    )
    register(
        "dancerevolution-small",
        None,
        str(RECIPES / "dancerevolution-small.yaml"),
        "DanceRevolution shrunk for CPU; learns the synthetic beats in about a minute",
    )
    register(
        "dancerevolution-real",
        None,
        str(RECIPES / "dancerevolution-real.yaml"),
        "DanceRevolution shrunk for CPU for real moves (train it with data.dataset.mocap; no weights ship)",
    )
    register(
        "cross-breed-small",
        None,
        str(RECIPES / "cross-breed-small.yaml"),
        "cross-breed: local-attention encoder (dance-rnn) + flow head (dance-flow)",
    )
