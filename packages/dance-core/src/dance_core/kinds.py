"""The component kinds: one row per kind, the table the registry, contracts and contexts read.

A ``Kind`` names its hook (declared in ``dance_core.hookspecs``, where pluggy and the docs need a
real function; a test checks the two agree), the protocol its components satisfy, the context its
builders receive, whether it holds trained weights, and its *capabilities*: the ``info`` keywords
``register`` accepts for it, as a pydantic model validated at registration.

Capabilities are what the registry must know **before** building a component (which file suffixes a
reader handles, which inputs a feature extractor reads). What a built component reports about
itself, which may depend on its options (a metric's ``needs``, an extractor's ``categorical``), stays
an attribute of the component, declared in its protocol.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from pydantic import BaseModel, ConfigDict, StrictBool, StrictInt, field_validator

from dance_core import protocols as p
from dance_core.contexts import ConditionerContext, DatasetContext, EncoderContext, HeadContext, NoContext


class Capabilities(BaseModel):
    """Base of the ``info`` keywords a kind accepts: unknown keywords are errors, values frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class FileCapabilities(Capabilities):
    """Audio readers: the suffixes handled (``(".wav",)``), and ``priority`` among readers of a suffix
    (higher wins; core's are 0)."""

    suffixes: tuple[str, ...] = ()
    priority: StrictInt = 0

    @field_validator("suffixes")
    @classmethod
    def _dotted(cls, suffixes: tuple[str, ...]) -> tuple[str, ...]:
        bad = [s for s in suffixes if not s.startswith(".") or len(s) < 2]
        if bad:
            raise ValueError(f"a suffix starts with a dot ('.bvh'), not {', '.join(map(repr, bad))}")
        return tuple(s.lower() for s in suffixes)


class FormatCapabilities(FileCapabilities):
    """Motion formats: as readers, plus ``write_only`` (previews: never chosen to read a file)."""

    write_only: StrictBool = False


class FeatureCapabilities(Capabilities):
    """Feature extractors: the inputs read (``("text",)`` makes compose and training gather text), and
    ``beats=True`` for a beat tracker (its first two columns are beat and downbeat one-hot frames, its
    ``tracker`` option the method): core's synthesizer and beat metrics find their tracker by it."""

    reads: tuple[Literal["audio", "text"], ...] = ("audio",)
    beats: StrictBool = False


@dataclass(frozen=True)
class Kind:
    """One component kind: its hook, protocol, build context, weights rule and capabilities."""

    name: str
    hook: str
    protocol: type | None
    context: type
    capabilities: type[Capabilities] | None
    description: str
    weights: bool = False  # holds trained weights: its components must be torch.nn.Modules

    def info_keywords(self) -> list[str]:
        """The ``info`` keywords ``register`` accepts for this kind."""
        return list(self.capabilities.model_fields) if self.capabilities is not None else []


_ROWS = (
    Kind("conditioner", "register_conditioners", p.Conditioner, ConditionerContext, None,
         "conditioners: per-frame embeddings of one input stream", weights=True),
    Kind("encoder", "register_encoders", p.Encoder, EncoderContext, None,
         "encoders: conditioning (and past motion) to a latent", weights=True),
    Kind("head", "register_heads", p.OutputHead, HeadContext, None,
         "output heads: latent to motion frames (loss and sampling)", weights=True),
    Kind("feature", "register_feature_extractors", p.FeatureExtractor, NoContext, FeatureCapabilities,
         "feature extractors: audio or text to frame-aligned features"),
    Kind("audio-reader", "register_audio_readers", p.AudioReader, NoContext, FileCapabilities,
         "audio readers: a file of some suffixes to samples and a rate"),
    Kind("motion-format", "register_motion_formats", p.MotionFormat, NoContext, FormatCapabilities,
         "motion formats: readers and writers of motion files"),
    Kind("motion-representation", "register_motion_representations", p.MotionRepresentation, NoContext, None,
         "motion representations: skeletal motion to model features ``(T, D)`` and back"),
    Kind("dataset", "register_datasets", p.Dataset, DatasetContext, None,
         "datasets: sources of paired music and motion clips"),
    Kind("metric", "register_metrics", p.Metric, NoContext, None,
         "evaluation metrics over generated and reference motion"),
    Kind("schedule", "register_schedules", p.Schedule, NoContext, None,
         "schedules: a value as a function of step and epoch (LR, curriculum)"),
    Kind("recipe", "register_recipes", None, NoContext, None, "bundled recipe files by name"),
)

#: kind name -> its row, in the order ``dance plugins`` lists them
KINDS: dict[str, Kind] = {kind.name: kind for kind in _ROWS}
