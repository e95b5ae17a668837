"""Pydantic configs of the flow plugin's components (no torch here, so registering them is cheap)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, PositiveFloat, PositiveInt, model_validator

from dance_core import ComponentConfig

Dropout = Field(0.0, ge=0.0, lt=1.0)


class TransformerConfig(ComponentConfig):
    """One transformer stack: depth, heads, feed-forward width, norm placement and positions.

    ``positions: relative`` is a T5-style bucketed bias, learned per head and shared by the layers
    of the stack (translation invariant); ``none`` uses no positional information.
    """

    layers: int = Field(2, ge=0)
    heads: PositiveInt = 8
    ffn: PositiveInt | None = Field(None, description="feed-forward width; default the model width")
    dropout: float = Dropout
    norm: Literal["pre", "post"] = "post"
    positions: Literal["relative", "none"] = "relative"
    buckets: PositiveInt = 32
    max_distance: PositiveInt = 128


class TransflowerEncoderConfig(ComponentConfig):
    """Motion and per-stream music transformers, then a cross-modal transformer over both.

    The latent is ``tokens`` vectors: the first ``tokens`` outputs (``latent: prefix``, as in the
    paper) or the outputs of ``tokens`` learned query tokens placed at the predicted frames' times
    (``latent: queries``).
    """

    motion_past: int = Field(120, ge=1)
    cond_past: int = Field(120, ge=0)
    cond_future: int = Field(20, ge=0)
    dim: PositiveInt = 800
    motion: TransformerConfig = Field(default_factory=lambda: TransformerConfig(layers=2, heads=10))
    music: TransformerConfig = Field(default_factory=lambda: TransformerConfig(layers=2, heads=10))
    crossmodal: TransformerConfig = Field(default_factory=lambda: TransformerConfig(layers=12, heads=10))
    tokens: PositiveInt = 3
    latent: Literal["prefix", "queries"] = "prefix"

    @model_validator(mode="after")
    def _window(self):
        if self.cond_past + self.cond_future == 0:
            raise ValueError("cond_past + cond_future must be at least 1 frame of music")
        for name in ("motion", "music", "crossmodal"):
            heads = getattr(self, name).heads
            if self.dim % heads:
                raise ValueError(f"{name}.heads ({heads}) must divide dim ({self.dim})")
        return self


class MoGlowContextConfig(ComponentConfig):
    """MoGlow's context: each of the last ``steps`` frames sees the concatenation of its recent
    ``motion_frames`` poses and ``music_past + music_future`` music frames; an LSTM runs over the
    ``steps`` positions and its last ``tokens`` outputs are the latent."""

    motion_frames: PositiveInt = 40
    music_past: PositiveInt = 40
    music_future: int = Field(10, ge=0)
    steps: PositiveInt = 8
    hidden: PositiveInt = 512
    layers: PositiveInt = 2
    dim: PositiveInt = 512
    tokens: PositiveInt = 1
    dropout: float = Dropout

    @model_validator(mode="after")
    def _tokens(self):
        if self.tokens > self.steps:
            raise ValueError(f"tokens ({self.tokens}) cannot exceed steps ({self.steps})")
        return self


class CouplingConfig(ComponentConfig):
    """The small transformer inside each affine coupling, acting over the N output frames."""

    dim: PositiveInt = 512
    layers: PositiveInt = 2
    heads: PositiveInt = 8
    ffn: PositiveInt | None = None
    dropout: float = Dropout
    norm: Literal["pre", "post"] = "post"
    positions: Literal["relative", "none"] = "relative"

    @model_validator(mode="after")
    def _heads(self):
        if self.dim % self.heads:
            raise ValueError(f"coupling.heads ({self.heads}) must divide coupling.dim ({self.dim})")
        return self


class FlowHeadConfig(ComponentConfig):
    """Glow-style flow over ``frames`` x D: ``steps`` x (norm -> LU 1x1 conv -> affine coupling).

    ``noise`` jitters training targets so that constant or nearly constant motion channels (joints
    that never move) have a bounded density instead of pulling the likelihood to infinity.
    ``residual`` models ``x_{t+i} - x_{t-1}`` (a translation: the likelihood of the frames is the same
    number), so the flow need not copy the last pose through the encoder. ``sample_correlation`` is a
    generation-time option (a checkpoint trained with another value still loads).
    """

    frames: PositiveInt = 3
    keep: PositiveInt = 1
    steps: PositiveInt = 16
    norm: Literal["actnorm", "batchnorm", "none"] = "batchnorm"
    momentum: float = Field(0.1, gt=0.0, le=1.0)
    coupling: CouplingConfig = Field(default_factory=CouplingConfig)
    base: Literal["gaussian", "student-t"] = "gaussian"
    df: PositiveFloat = 50.0
    noise: float = Field(0.01, ge=0.0, description="std of Gaussian noise added to training targets (normalized units)")
    residual: bool = Field(False, description="model the frames minus the last frame before them")
    sample_correlation: float = Field(
        0.0, ge=0.0, lt=1.0, json_schema_extra={"generation": True},
        description="generation only: correlation of the base noise between consecutive steps (AR(1); 0: "
        "independent, as in the paper). Each step's noise keeps its distribution, so the dance keeps its "
        "variety, but consecutive frames share most of it instead of jittering apart",
    )

    @model_validator(mode="after")
    def _keep(self):
        if self.keep > self.frames:
            raise ValueError(f"keep ({self.keep}) cannot exceed frames ({self.frames})")
        return self
