"""Pydantic configs of dance-audio's components (a light module: registering imports nothing heavy)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, PositiveFloat, PositiveInt

from dance_core import ComponentConfig


class SoundFileReaderConfig(ComponentConfig):
    """No options: files are mixed to mono at their own rate (extractors resample)."""


class Librosa438Config(ComponentConfig):
    """DanceRevolution's 438-d set; audio is resampled to ``hop_length * fps`` Hz (15360 at 30 fps).

    ``port`` computes it with dance-audio's own DSP (fast, no librosa); ``librosa`` with librosa's
    own calls (``pip install 'dance-audio[librosa]'``). The two agree within the tested tolerances,
    so the backend is a generation-time choice that checkpoint matching skips.
    """

    hop_length: PositiveInt = 512
    n_fft: PositiveInt = 2048
    n_mels: PositiveInt = 128
    tempogram_window: PositiveInt = 384
    backend: Literal["port", "librosa"] = Field(
        "port", json_schema_extra={"generation": True},
        description="port: dance-audio's own DSP, equal to librosa's (default); librosa: librosa itself "
        "(the dance-audio[librosa] extra)",
    )


class MelConfig(ComponentConfig):
    """Log-mel bands (dB) centred at i / fps; the window must cover the hop."""

    n_mels: PositiveInt = 80
    sample_rate: PositiveInt = 22050
    n_fft: PositiveInt = 2048
    fmin: float = Field(0.0, ge=0.0)
    fmax: PositiveFloat | None = None
    reference: Literal["max", "one"] = "one"


class OnsetConfig(ComponentConfig):
    """Spectral-flux onset strength on a mel spectrogram (librosa), centred at i / fps."""

    n_mels: PositiveInt = 80
    sample_rate: PositiveInt = 22050
    n_fft: PositiveInt = 2048


class DownbeatConfig(ComponentConfig):
    """madmom's joint beat/downbeat RNN at 100 fps, resampled to the recipe's fps.

    ``port`` runs madmom's network weights in dance's own NumPy/numba port (fast, equal to madmom
    within 1e-4); ``madmom`` runs madmom's own processor (slow, for checking).
    """

    backend: Literal["port", "madmom"] = "port"


class BeatsConfig(ComponentConfig):
    """Beat and downbeat times as one-hot frames and phases (sin, cos) within beat and bar.

    The default tracker (``flux``) reads no model file and follows tempo changes; ``librosa`` (one global
    tempo) stays selectable; madmom's (non-commercial weights) is read only when asked for.

    The tempo range is a dance prior: beyond 160 BPM trackers mostly return the double of the
    danced tempo (AIST++ music spans 80-135 BPM), so the default stops there (madmom's is 215).
    """

    tracker: Literal["flux", "librosa", "madmom", "auto"] = Field(
        "flux", json_schema_extra={"generation": True},
        description="beat tracker: flux (default; dance-audio's bar-pointer HMM over beat phase and tempo on its "
        "own bass-weighted spectral flux: follows tempo changes, no model files), librosa (dance-audio's own "
        "implementation of librosa's dynamic-programming tracker, one global tempo, no model files), madmom "
        "(madmom's DBN on its downbeat network, whose weight files are CC BY-NC-SA 4.0, non-commercial: an opt-in, "
        "needs the dance-audio[madmom] extra) or auto (an opt-in too: madmom when installed, else flux). The "
        "columns mean the same whichever tracked them, so a model trained on one tracker's beats may compose "
        "with another's",
    )
    beats_per_bar: list[PositiveInt] = Field(default_factory=lambda: [3, 4])
    min_bpm: PositiveFloat = 55.0
    max_bpm: PositiveFloat = 160.0


class WordEmbeddingConfig(ComponentConfig):
    """Token ids of each frame's instruction for a learned embedding (TM2D), from a vocabulary file."""

    vocab: str = Field(json_schema_extra={"path": True},
                       description="vocabulary file, one word per line (relative: to the recipe that names it)")
    max_words: PositiveInt = 32


class GloveConfig(ComponentConfig):
    """Mean GloVe vector of each frame's instruction, from a user-supplied text file."""

    path: str = Field(json_schema_extra={"path": True},
                      description="GloVe text file (relative: to the recipe that names it)")
    dim: PositiveInt = 300


class SentenceEmbeddingConfig(ComponentConfig):
    """all-MiniLM-L6-v2 sentence embedding (384-d) of each frame's instruction, offline."""

    normalize: bool = True
