"""Entry module: registers the ``loudness`` extractor. Nothing heavy is imported here."""

from __future__ import annotations

from pydantic import Field

from dance_core import ComponentConfig, hookimpl


class LoudnessConfig(ComponentConfig):
    """Window length in seconds and the floor of the decibel scale."""

    window: float = Field(0.05, gt=0.0, le=1.0)
    floor_db: float = -80.0


@hookimpl
def register_feature_extractors(register):
    """Register ``loudness``."""
    register("loudness", LoudnessConfig, "dance_loudness.loudness:build", "RMS loudness in dB")
