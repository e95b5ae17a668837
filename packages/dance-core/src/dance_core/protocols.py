"""The component protocols that every model family implements.

Tensors are batch-first ``(B, T, C)`` and in normalized units. See docs/architecture.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from dance_core.media import Audio, FeatureInputs, TextSpan
from dance_core.spans import TextSpans

if TYPE_CHECKING:  # torch is imported lazily everywhere else
    import torch


@dataclass(frozen=True)
class Window:
    """What an encoder sees per step.

    ``cond_past=None`` makes a *song-level* encoder: no motion, the whole conditioning sequence at
    once, and a per-frame latent out. Otherwise the encoder sees ``motion_past`` motion frames
    before step time ``t`` and conditioning frames ``[t - cond_past, t + cond_future)``.
    """

    motion_past: int = 0
    cond_past: int | None = 0
    cond_future: int = 0

    @property
    def song_level(self) -> bool:
        """True when the encoder runs once over the whole song."""
        return self.cond_past is None


@dataclass
class TrainContext:
    """Where training stands, handed to every loss: step, epoch, stage and schedule values.

    ``streams``: for heads behind a song-level encoder, the conditioned feature streams aligned with
    the latent and target of this ``loss`` call (a head that reads an input the encoder does not
    summarize); ``None`` behind windowed encoders. ``spans``: likewise, the batch's text spans aligned
    with them (a ``TextSpans`` table: each span, its frames, per frame the span in force and one row
    of features per span, such as TM2D's sentences); ``None`` behind windowed encoders or when the
    caller has none. ``kinematics``: the joint positions ``(..., T, J, 3)`` of standardized motion
    ``(..., T, D)``, differentiable (``dance_core.motion.torch_fk.RotationKinematics``), for a loss on
    positions; ``None`` unless the motion is the ``rotations`` representation.
    """

    step: int
    epoch: int
    stage: str = "main"
    values: dict[str, float] = field(default_factory=dict)
    generator: Any = None
    streams: dict[str, Any] | None = None
    spans: TextSpans | None = None
    kinematics: Any = None


@dataclass
class SongInputs:
    """What a head behind a song-level encoder sees before it generates: the whole song's latent
    ``(B, T, d)``, conditioned streams ``(B, T, C)`` and text spans (a ``TextSpans`` over the same
    ``T`` frames, or None), frame-aligned, padded by the head's ``frames``."""

    latent: Any
    streams: dict[str, Any]
    spans: TextSpans | None = None


@runtime_checkable
class Conditioner(Protocol):
    """Per-frame embedding of one input stream: ``(B, T, in_dim) -> (B, T, out_dim)`` (the stream's
    name and width arrive in its ``ConditionerContext``)."""

    out_dim: int

    def __call__(self, features: torch.Tensor) -> torch.Tensor:
        """Embed one frame-aligned stream."""
        ...


@runtime_checkable
class Encoder(Protocol):
    """Conditioning streams (and past motion) to a latent ``(B, K, d)`` or ``(B, T, d)``."""

    window: Window
    latent_tokens: int | None
    out_dim: int

    def __call__(
        self, motion: torch.Tensor | None, cond: Mapping[str, torch.Tensor]
    ) -> torch.Tensor:
        """Encode one window (or, for a song-level encoder, the whole sequence)."""
        ...


@runtime_checkable
class OutputHead(Protocol):
    """Latent to motion frames: a training loss and a sampling step."""

    frames: int
    keep: int
    history_frames: int
    latent_tokens: int | None

    def loss(
        self,
        latent: torch.Tensor,
        target: torch.Tensor,
        history: torch.Tensor,
        ctx: TrainContext,
    ) -> dict[str, torch.Tensor]:
        """Training losses; ``"loss"`` is the one optimized."""
        ...

    def init_state(self, batch: int, generator: torch.Generator | None, song: SongInputs | None = None) -> Any:
        """Generation state before the first step (for instance an LSTM's h0). Behind a song-level
        encoder core also passes ``song`` (the whole song's latent and streams) so that a sequence
        head can plan over the song (TM2D's text spans); behind a windowed encoder it is not passed."""
        ...

    def step(
        self,
        latent: torch.Tensor,
        history: torch.Tensor,
        state: Any,
        temperature: float,
        generator: torch.Generator | None,
    ) -> tuple[torch.Tensor, Any]:
        """Sample the next ``frames`` frames ``(B, frames, D)`` and the new state."""
        ...

    def finish(self, motion: torch.Tensor, state: Any) -> torch.Tensor:
        """Post-process the whole generated motion (identity for most heads)."""
        ...


@runtime_checkable
class LiveStream(Protocol):
    """Live generation behind a song-level encoder whose latent reads a bounded neighbourhood of music
    (``dance live``): what a head's optional hook ``live_stream(encoder, lookahead, generator, temperature)``
    gives, or None when the encoder reads the whole song (then the model cannot dance live). ``lookahead``:
    frames of music past a step's frames it may wait for (None: the head's default; a value at least the
    model's whole reach gives ``dance compose``'s frames exactly). Batch of one, normalized motion."""

    t: int  # frames given out or skipped so far
    lookahead: int  # the most frames of music past a frame's own that it waits for

    def add(self, cond: Mapping[str, torch.Tensor]) -> None:
        """Append conditioned music frames ``{stream: (1, k, C)}``."""
        ...

    def end(self) -> None:
        """No more music."""
        ...

    def ready(self) -> int:
        """Frames that may be given now."""
        ...

    def step(self) -> torch.Tensor:
        """The next frames ``(k, D)`` (empty when none is ready)."""
        ...

    def skip(self, n: int) -> None:
        """Drop about ``n`` of the next frames (the head says how it holds the dance meanwhile)."""
        ...

    def newest(self, frame: int) -> int:
        """The last music frame that frame ``frame`` waits for."""
        ...

    def first_open(self) -> int:
        """The first frame not generated yet: a text span given now can act from there on."""
        ...

    def texts(self, spans: TextSpans | None) -> None:
        """The text spans known now (one row, over the frames from the song's start); replaces earlier ones."""
        ...


@runtime_checkable
class FeatureExtractor(Protocol):
    """Audio and/or text to ``(n_frames, dim)`` float32 features at ``fps``.

    An extractor whose columns are ids (word tokens) sets ``categorical = True``: core then leaves
    them unstandardized, so a model can embed them.
    """

    def dim(self) -> int:
        """Feature width."""
        ...

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """Features for ``inputs.n_frames`` frames; frame i describes time i / fps."""
        ...


@runtime_checkable
class SpanFeatureExtractor(FeatureExtractor, Protocol):
    """A text extractor that gives one row of features per text span; core lays the rows over the
    frames for the per-frame stream (zeros where no span is in force) and keeps them as the stream's
    rows of the song's span table (``SpanTable``, ``TextSpans``) when every extractor of the stream
    gives them. Its ``extract`` gives the same per-frame values (``SpanTable.per_frame``)."""

    def span_features(self, texts: tuple[TextSpan, ...]) -> np.ndarray:
        """``(len(texts), dim())`` float32: one row per span, in order."""
        ...


@runtime_checkable
class AudioReader(Protocol):
    """Reads audio files of some suffixes (registered with ``suffixes=(...)``)."""

    def read(self, path: str) -> Audio:
        """Mono float32 samples and their rate."""
        ...


@dataclass
class MotionData:
    """Motion as a frame array ``(T, D)`` at ``fps``, with optional per-channel names.

    ``skeleton_motion`` is the skeletal motion (a ``dance_core.motion.Motion``) that the values
    encode or were read from, when there is one: skeleton formats (BVH, SMPL) need it to write.
    """

    values: np.ndarray
    fps: float
    channels: Sequence[str] | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    skeleton_motion: Any = None


@runtime_checkable
class MotionFormat(Protocol):
    """Reads and writes one motion file format (registered with ``suffixes=(...)``)."""

    def read(self, path: str) -> MotionData:
        """Load a motion file."""
        ...

    def write(self, motion: MotionData, path: str) -> None:
        """Write a motion file (atomically)."""
        ...


@runtime_checkable
class MotionRepresentation(Protocol):
    """Skeletal motion (a ``dance_core.motion.Motion``) to model features ``(T, D)`` and back."""

    def channels(self, skeleton: Any) -> list[str]:
        """Names of the ``D`` feature channels for a skeleton."""
        ...

    def dim(self, skeleton: Any) -> int:
        """``D``, the feature width for a skeleton."""
        ...

    def encode(self, motion: Any) -> np.ndarray:
        """Features ``(T, D)`` of a motion."""
        ...

    def decode(self, values: np.ndarray, skeleton: Any, fps: float) -> Any:
        """The motion that features ``(T, D)`` describe, on ``skeleton`` at ``fps``."""
        ...


@runtime_checkable
class Dataset(Protocol):
    """A source of paired music and motion clips."""

    def clips(self) -> Sequence[Any]:
        """Every clip as a ``dance_core.data.ClipSource``."""
        ...


@runtime_checkable
class Schedule(Protocol):
    """A value as a function of training progress (LR multiplier, curriculum length...)."""

    def __call__(self, step: int, epoch: int, total_steps: int) -> float:
        """The value at this point of training."""
        ...


@dataclass
class JointClip:
    """One dance as joint positions for evaluation: ``(T, J, 3)`` in metres, Y up, at ``fps``.

    ``music_beats`` are the beat times (seconds) of the clip's music, when known.
    """

    name: str
    positions: np.ndarray
    fps: float
    joints: Sequence[str] | None = None
    music_beats: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return len(self.positions) / self.fps


@dataclass
class MetricResult:
    """A metric's summary values, optional per-clip values, and notes about skipped clips."""

    values: dict[str, float]
    per_clip: dict[str, dict[str, float]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


@runtime_checkable
class Metric(Protocol):
    """A score of a set of generated dances, optionally against a reference set and music beats.

    ``needs`` names what the metric cannot do without: ``"reference"`` (a reference set) and/or
    ``"music"`` (``music_beats`` on the clips). A metric that cannot score its input raises a
    ``DataError`` naming the clip and the reason.
    """

    needs: tuple[str, ...]

    def __call__(
        self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None
    ) -> MetricResult:
        """Score the generated set."""
        ...
