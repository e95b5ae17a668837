"""Entry module of the ``tokens`` plugin: registers components lazily (no torch imported here)."""

from __future__ import annotations

from pathlib import Path

from dance_core import hookimpl
from dance_tokens import configs as c

RECIPES = Path(__file__).resolve().parent / "recipes"


@hookimpl
def register_encoders(register):
    """TM2D's audio encoder."""
    register(
        "tm2d-audio",
        c.AudioEncoderConfig,
        "dance_tokens.encoder:build",
        "song-level: music at the token rate, linear embedding, transformer encoder (TM2D)",
    )


@hookimpl
def register_heads(register):
    """TM2D's motion VQ-VAE and cross-modal token prior."""
    register(
        "tm2d",
        c.TM2DHeadConfig,
        "dance_tokens.head:build",
        "motion VQ-VAE tokens + causal decoder over audio or text, late fusion, top-k (TM2D)",
    )


@hookimpl
def register_recipes(register):
    """TM2D at the paper's sizes and a CPU-sized variant."""
    register("tm2d", None, str(RECIPES / "tm2d.yaml"), "TM2D at the paper's sizes (music + text; needs a GPU)")
    register(
        "tm2d-small", None, str(RECIPES / "tm2d-small.yaml"), "TM2D shrunk for CPU: trains on one CPU thread in 35 min"
    )
