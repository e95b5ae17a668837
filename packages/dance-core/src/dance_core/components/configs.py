"""Pydantic configs of core's components (kept apart so registering them imports no torch)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, PositiveFloat, PositiveInt

from dance_core.config import ComponentConfig


class MLPConditionerConfig(ComponentConfig):
    """Per-frame MLP: ``layers`` linear layers of width ``dim``."""

    dim: PositiveInt = 64
    layers: PositiveInt = 2
    dropout: float = Field(0.0, ge=0.0, lt=1.0)


class WindowMLPConfig(ComponentConfig):
    """Window sizes in frames, and the MLP that maps the flattened window to latent tokens."""

    motion_past: int = Field(8, ge=0)
    cond_past: int = Field(8, ge=0)
    cond_future: int = Field(4, ge=0)
    hidden: PositiveInt = 256
    layers: PositiveInt = 2
    dim: PositiveInt = 128
    tokens: PositiveInt = 1
    dropout: float = Field(0.0, ge=0.0, lt=1.0)


class RegressionHeadConfig(ComponentConfig):
    """Frames predicted per step, frames kept, and the loss."""

    frames: PositiveInt = 1
    keep: PositiveInt | None = None
    loss: Literal["l1", "l2"] = "l1"
    hidden: PositiveInt = 256


class EnergyConfig(ComponentConfig):
    """STFT size, band edges in Hz and the onset smoothing."""

    n_fft: PositiveInt = 2048
    bands: list[PositiveFloat] = Field(default_factory=lambda: [200.0, 2000.0])
    log_floor: PositiveFloat = 1e-6


class ConstantConfig(ComponentConfig):
    """The value."""

    value: float = 1.0


class CosineConfig(ComponentConfig):
    """Warm-up steps and the final fraction of the start value."""

    warmup: int = Field(0, ge=0)
    floor: float = Field(0.05, ge=0.0, le=1.0)


class MultiStepConfig(ComponentConfig):
    """Warm-up steps, milestone steps and the factor applied at each."""

    warmup: int = Field(0, ge=0)
    milestones: list[PositiveInt] = Field(default_factory=list)
    gamma: PositiveFloat = 0.1
