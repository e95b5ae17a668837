"""Pydantic configs of the rnn plugin's components (kept apart so registering them imports no torch).

Defaults follow the DanceRevolution paper (ICLR 2021, section 4.2); the small recipe shrinks them.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, NonNegativeInt, PositiveFloat, PositiveInt

from dance_core import ComponentConfig


class LocalAttentionConfig(ComponentConfig):
    """Local self-attention music encoder: each frame attends to its ``k`` nearest neighbours.

    ``k`` follows the paper: frame ``i`` sees frames ``j`` with ``|i - j| <= k // 2`` (the reference
    code's ``sliding_windown_size`` is that half-width, not ``k``).
    """

    streams: list[str] | None = Field(
        None, description="conditioning streams concatenated as input; default all, sorted by name"
    )
    dim: PositiveInt = Field(1024, description="hidden size d_z (the embedding and every layer)")
    layers: PositiveInt = 2
    heads: PositiveInt = 8
    head_dim: PositiveInt = Field(64, description="d_k = d_v per head")
    ff_dim: PositiveInt = Field(1024, description="hidden units of the position-wise feed-forward")
    k: NonNegativeInt = Field(100, description="receptive field: |i - j| <= k // 2")
    position: Literal["relative", "sinusoidal", "none"] = Field(
        "relative",
        description="relative: a learned bias per head and offset (length-independent); "
        "sinusoidal: absolute positions added to the embedding (the reference code)",
    )
    dropout: float = Field(0.1, ge=0.0, lt=1.0)
    block: PositiveInt | None = Field(
        None, description="query block length of the banded kernel; default max(k // 2, 16)"
    )


class LSTMHeadConfig(ComponentConfig):
    """Stacked LSTM dance decoder with ``h0 ~ N(0, I)`` and dynamic auto-condition training."""

    hidden: PositiveInt = Field(512, description="d_s, hidden units of every LSTM layer")
    layers: PositiveInt = 3
    pose_dim: PositiveInt | None = Field(
        None, description="width of the linear pose embedding before the LSTM; default the motion width"
    )
    dropout: float = Field(0.0, ge=0.0, lt=1.0, description="between LSTM layers and on the pose")
    teacher_frames: PositiveInt = Field(10, description="p: ground-truth inputs per period")
    auto_condition: str | None = Field(
        "auto_condition",
        description="name of the training schedule giving q (generated inputs per period); "
        "null trains with teacher forcing only",
    )
    init_scale: float = Field(1.0, ge=0.0, description="std of the random initial state h0, c0")


class CurriculumConfig(ComponentConfig):
    """Growth of q with the epoch ``t = epoch + offset``: ``min(limit, floor(f(t)))``."""

    rate: PositiveFloat = Field(0.01, description="lambda")
    offset: int = Field(1, description="core counts epochs from 0, the paper from 1")
    limit: NonNegativeInt | None = Field(None, description="largest q (needed for the exponential)")


class ConstantCurriculumConfig(ComponentConfig):
    """A fixed q: static auto-condition (Li et al., 2017)."""

    value: NonNegativeInt = 10


class ExponentialCurriculumConfig(CurriculumConfig):
    """``floor(lambda * e^t)``, always capped by ``limit`` so it never overflows."""

    limit: NonNegativeInt = Field(1000, description="largest q")
