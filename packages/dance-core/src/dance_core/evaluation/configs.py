"""Pydantic configs of the registered metrics (a light module: registering imports no numpy code)."""

from __future__ import annotations

from pydantic import Field, PositiveFloat, PositiveInt, model_validator

from dance_core.config import ComponentConfig


class FeatureMetricConfig(ComponentConfig):
    """``compat: true`` reproduces the AIST++/Bailando feature bugs (see ``evaluation.kinetic``)."""

    compat: bool = False


class BailandoBASConfig(ComponentConfig):
    """Speed smoothing and score width in seconds (5 and 3 frames at 60 fps in Bailando)."""

    smooth_seconds: float = Field(5 / 60, ge=0.0)
    sigma_seconds: PositiveFloat = 3 / 60


class FactBASConfig(ComponentConfig):
    """Minimum search half-width and score width in seconds (10 and 3 frames at 60 fps in FACT)."""

    order_seconds: PositiveFloat = 10 / 60
    sigma_seconds: PositiveFloat = 3 / 60


class FreezingConfig(ComponentConfig):
    """TM2D's freezing threshold (m/s) and minimum duration (s); AUC_f threshold range and steps;
    ``relative``: PFF_rel's threshold as a fraction of the reference's median largest joint speed."""

    threshold: PositiveFloat = 0.015
    min_seconds: PositiveFloat = 3.0
    auc_max: PositiveFloat = 0.03
    auc_steps: PositiveInt = Field(31, ge=2)
    relative: float = Field(0.1, gt=0.0, le=1.0)


class FrechetPoseConfig(ComponentConfig):
    """Poses in their own body frame (``hips``: left and right hip joint names, default SMPL-24 or known
    names); ``compat: true``: in world orientation, with ``root_relative`` removing the root's
    horizontal position from every frame (the earlier definition)."""

    compat: bool = False
    root_relative: bool = True
    hips: list[str] | None = Field(None, min_length=2, max_length=2)


class BeatOffsetConfig(ComponentConfig):
    """The hips joint (name; default the root joint) and optional smoothing of its velocity (s)."""

    hips: str | None = None
    smooth_seconds: float = Field(0.0, ge=0.0)


class BeatLockingConfig(ComponentConfig):
    """The hips joint (name; default the root joint) and the wrong-tempo control grid's tempo factor."""

    hips: str | None = None
    control_tempo: float = Field(1.13, gt=0.0)


class BeatCoverageConfig(ComponentConfig):
    """Tolerance (s) for a kinematic beat to hit a music beat; speed smoothing of the detector (s)."""

    tolerance_seconds: PositiveFloat = 0.1
    smooth_seconds: float = Field(5 / 60, ge=0.0)


class SampleDiversityConfig(ComponentConfig):
    """Left and right hip joint names for the body frame (default: SMPL-24 or known names)."""

    hips: list[str] | None = Field(None, min_length=2, max_length=2)


class RealismConfig(ComponentConfig):
    """Seconds between the starts of the 4-s windows the statistics are taken over."""

    hop_seconds: PositiveFloat = 0.5


class RepetitionConfig(ComponentConfig):
    """No options: the last 40 s against the same stretch 0.5-20 s earlier (``evaluation.repetition``)."""


class BodyLockingConfig(ComponentConfig):
    """No options: accents are the body's own (``dance_core.motion.body.body_beats``)."""


class PFCConfig(ComponentConfig):
    """Left ankle, left toe, right ankle, right toe joint names (default: SMPL-24 or known names)."""

    feet: list[str] | None = Field(None, min_length=4, max_length=4)


class MPDConfig(ComponentConfig):
    """TM2D's MPD: frame counts at ``fps`` (None: the reference's), futures ``k``, points and the predictor.

    ``past``/``future`` frames before/after each evaluation point, values at future frames ``at``;
    clips without texts are scored every ``stride`` seconds; one reference window every
    ``reference_step`` frames; reference clips named like the scored clip are left out
    (``exclude_same_name``); ``hips``: left and right hip joint names (default: SMPL-24 or known names).
    """

    fps: PositiveFloat | None = 60.0
    past: PositiveInt = 25
    future: PositiveInt = 30
    at: list[PositiveInt] = Field(default_factory=lambda: [10, 20, 30], min_length=1)
    k: PositiveInt = 10
    stride: PositiveFloat = 2.0
    reference_step: PositiveInt = 1
    exclude_same_name: bool = True
    hips: list[str] | None = Field(None, min_length=2, max_length=2)

    @model_validator(mode="after")
    def _at_within_future(self) -> MPDConfig:
        if any(a > self.future for a in self.at):
            raise ValueError(f"at={self.at}: every future frame must be at most future={self.future}")
        return self


class MoveValidityConfig(ComponentConfig):
    """A bar is valid within ``threshold`` m (RMS joint distance) of a move template; the meters tried."""

    threshold: PositiveFloat = 0.025
    meters: list[int] = Field(default_factory=lambda: [3, 4], min_length=1)

    @model_validator(mode="after")
    def _meters(self) -> MoveValidityConfig:
        if any(not 2 <= m <= 7 for m in self.meters):
            raise ValueError(f"meters={self.meters}: beats per bar must lie within 2-7")
        return self
