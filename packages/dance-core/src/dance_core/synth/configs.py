"""Pydantic configs of the synthesizer's datasets (light: registering them imports no heavy module)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, PositiveFloat, PositiveInt, field_validator

from dance_core.config import ComponentConfig


class SyntheticDanceConfig(ComponentConfig):
    """Songs, their length and tempo range, dances per song and their dancers, and the dancer's frame rate."""

    songs: PositiveInt = 24
    seconds: PositiveFloat = 30.0
    bpm: tuple[PositiveFloat, PositiveFloat] = (80.0, 140.0)
    dances_per_song: PositiveInt = 1
    sample_rate: PositiveInt = 22050
    motion_fps: PositiveFloat | None = Field(None, description="frame rate of the dancer; default the recipe's")
    seed: int = 0
    dance_to_tracker: Literal["flux", "librosa", "madmom", "auto"] | None = Field(
        None, description="dance to the beats this tracker hears (the registered 'beats' extractor) instead of "
        "the true beats: the tempo octave a model reading that tracker's features will hear in real songs"
    )
    dancers: list[str] | None = Field(
        default_factory=lambda: ["classic"],
        description="dancers of the dances (names of synth.dancer.DANCERS), a different one per dance of a song "
        "as far as they go; None: all (the multimodal set); default the classic dancer alone (the dances of before)",
    )
    homogeneous: bool = Field(False, description="the control set: every dance by the first dancer, in one style "
                              "and one fixed routine (a song's dances are then the same)")
    mocap: str | None = Field(
        None, json_schema_extra={"path": True},
        description="a folder of motion-capture takes (any rig): dances are chained from these real moves "
        "(synth.motion_graph) instead of the procedural dancer; relative to the recipe")
    mocap_files: list[str] | None = Field(None, description="file name patterns of the takes to use (default all)")
    mocap_exclude: list[str] = Field(default_factory=list, description="file name patterns of takes to leave out "
                                     "(held out for evaluation)")

    @field_validator("dancers")
    @classmethod
    def _dancers(cls, v: list[str] | None) -> list[str] | None:
        from dance_core.synth.dancer import dancer_names

        return None if v is None else dancer_names(v)


def _ordered(pair: tuple[float, float], what: str) -> tuple[float, float]:
    """A ``(low, high)`` range, checked."""
    if pair[0] > pair[1]:
        raise ValueError(f"{what} range ({pair[0]:g}, {pair[1]:g}) runs backwards: give (low, high)")
    return pair


class SyntheticMovesConfig(ComponentConfig):
    """Text-motion clips of the synthetic dancer: one labelled move each, no music (TM2D's text corpus)."""

    clips: PositiveInt = 200
    seconds: tuple[PositiveFloat, PositiveFloat] = Field((2.0, 10.0), description="clip length range, seconds")
    bpm: tuple[PositiveFloat, PositiveFloat] = Field((80.0, 140.0), description="tempo range of the (unheard) count")
    moves: list[str] | None = Field(None, description="moves to perform (names of synth.dancer.MOVES); None: all")
    rest: float = Field(0.5, ge=0.0, le=1.0, description="chance that a clip starts from the rest pose (and, "
                        "drawn apart, that it ends in it)")
    sample_rate: PositiveInt = Field(22050, description="rate of the silent audio every clip carries")
    motion_fps: PositiveFloat | None = Field(None, description="frame rate of the dancer; default the recipe's")
    seed: int = 0

    @field_validator("seconds")
    @classmethod
    def _seconds(cls, v: tuple[float, float]) -> tuple[float, float]:
        if v[0] < 1.0:
            raise ValueError(f"clips must last at least 1 s, got {v[0]:g}")
        return _ordered(v, "seconds")

    @field_validator("bpm")
    @classmethod
    def _bpm(cls, v: tuple[float, float]) -> tuple[float, float]:
        return _ordered(v, "bpm")

    @field_validator("moves")
    @classmethod
    def _moves(cls, v: list[str] | None) -> list[str] | None:
        from dance_core.synth.dancer import MOVES

        if v is not None:
            unknown = [m for m in v if m not in MOVES]
            if unknown or not v:
                raise ValueError(f"unknown move(s) {', '.join(unknown) or '(none given)'}; known: {', '.join(MOVES)}")
        return v
