"""Pydantic configs of the motion datasets (light: registering them imports no heavy module)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, PositiveFloat, PositiveInt

from dance_core.config import ComponentConfig


class SyntheticDanceConfig(ComponentConfig):
    """Songs, their length and tempo range, dances per song, and the dancer's frame rate."""

    songs: PositiveInt = 24
    seconds: PositiveFloat = 30.0
    bpm: tuple[PositiveFloat, PositiveFloat] = (80.0, 140.0)
    dances_per_song: PositiveInt = 1
    sample_rate: PositiveInt = 22050
    motion_fps: PositiveFloat | None = Field(None, description="frame rate of the dancer; default the recipe's")
    seed: int = 0
    dance_to_tracker: Literal["librosa", "madmom", "auto"] | None = Field(
        None, description="dance to the beats this tracker hears (the registered 'beats' extractor) instead of "
        "the true beats: the tempo octave a model reading that tracker's features will hear in real songs"
    )


class FolderDatasetConfig(ComponentConfig):
    """A folder of ``name.<audio>`` + ``name.<motion>`` pairs (relative to the recipe)."""

    path: str
    max_offset: float = Field(0.5, ge=0.0, description="largest allowed audio/motion length difference, seconds")
    cache: str | None = Field(None, description="feature cache folder; default <path>/.dance-cache")


class AistDatasetConfig(ComponentConfig):
    """The AIST++ layout: ``motions/*.pkl``, ``wav/*.wav``, ``splits/*.txt``."""

    path: str
    split: str | None = Field("crossmodal_train", description="split list name (splits/<name>.txt); None: all")
    max_offset: float = Field(1.0, ge=0.0)


class HumanMLConfig(ComponentConfig):
    """HumanML3D: ``new_joints/*.npy`` (T, 22, 3) at 20 fps and ``texts/*.txt``; audio in ``audio/`` when any."""

    path: str
    split: str | None = Field("train", description="split list (<path>/<split>.txt); None: all")
    fps: PositiveFloat = 20.0
