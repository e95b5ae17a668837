"""Markers of a dance for animators: the song's beats, downbeats and sections, and the feet's contacts.

Times are seconds from the dance's first frame, so they hold at any frame rate. They travel in a
``.markers.json`` sidecar beside a motion file (:func:`write_markers`, :func:`read_markers`), in a glb's
animation extras, and onto Blender's timeline through the script ``dance convert --blender-script``
writes. Beats and sections come from the song (``evaluation.song_markers``); contacts from the motion
itself (:func:`contact_spans`, the grounding step's contact detection).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.atomic import write_text
from dance_core.errors import DataError
from dance_core.motion.motion import Motion

#: the sidecar's suffix, after the motion file's stem
SIDECAR = ".markers.json"
VERSION = 1
SIDES = ("left", "right")


@dataclass
class Markers:
    """Beat and downbeat times, named sections ``(name, start, end)`` and, per foot (``left``,
    ``right``), contact spans ``(start, end)``; all in seconds."""

    beats: list[float] = field(default_factory=list)
    downbeats: list[float] = field(default_factory=list)
    sections: list[tuple[str, float, float]] = field(default_factory=list)
    contacts: dict[str, list[tuple[float, float]]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The JSON-able form (the sidecar's content and the glb extras)."""
        r = lambda x: round(float(x), 4)  # noqa: E731 - a tenth of a millisecond is plenty
        return {"version": VERSION, "beats": [r(t) for t in self.beats], "downbeats": [r(t) for t in self.downbeats],
                "sections": [{"name": n, "start": r(a), "end": r(b)} for n, a, b in self.sections],
                "contacts": {s: [[r(a), r(b)] for a, b in spans] for s, spans in self.contacts.items()}}

    @classmethod
    def from_dict(cls, data: Any, where: str) -> Markers:
        """Markers from their JSON form; anything malformed is one ``DataError`` naming ``where`` and the field."""
        if not isinstance(data, dict):
            raise DataError(f"{where}: markers must be an object")
        out = cls()
        for key in ("beats", "downbeats"):
            setattr(out, key, _times(data.get(key, []), f"{where}: markers.{key}"))
        sections = data.get("sections", [])
        if not isinstance(sections, list):
            raise DataError(f"{where}: markers.sections must be a list")
        for i, s in enumerate(sections):
            at = f"{where}: markers.sections[{i}]"
            if not isinstance(s, dict) or not isinstance(s.get("name"), str):
                raise DataError(f"{at}: needs a name, a start and an end")
            start, end = _times([s.get("start"), s.get("end")], at)
            out.sections.append((s["name"][:200], start, end))
        contacts = data.get("contacts", {})
        if not isinstance(contacts, dict) or set(contacts) - set(SIDES):
            raise DataError(f"{where}: markers.contacts must map left and right to spans")
        for side, spans in contacts.items():
            if not isinstance(spans, list):
                raise DataError(f"{where}: markers.contacts.{side} must be a list of [start, end]")
            pairs = [_times(p if isinstance(p, list) and len(p) == 2 else [None], f"{where}: markers.contacts.{side}")
                     for p in spans]
            out.contacts[side] = [(a, b) for a, b in pairs]
        return out


def _times(values: Any, where: str) -> list[float]:
    if not isinstance(values, list):
        raise DataError(f"{where}: must be a list of times in seconds")
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v < 0:
            raise DataError(f"{where}: {v!r} is not a time in seconds (a finite number >= 0)")
        out.append(float(v))
    return out


def contact_spans(motion: Motion) -> dict[str, list[tuple[float, float]]]:
    """Per foot, the spans (seconds) it is planted on the floor, found as grounding finds them; empty
    when the motion has no rotations or its skeleton no recognisable feet."""
    from dance_core.motion.grounding import (
        GroundingOptions,
        _runs,
        find_feet,
        foot_contacts,
        foot_speeds,
        metres_per_unit,
        sole_heights,
    )

    feet = find_feet(motion.skeleton) if motion.rotations is not None else None
    if feet is None or motion.n_frames < 2:
        return {}
    options = GroundingOptions()
    unit = metres_per_unit(motion.skeleton, feet, options)
    pos = motion.positions(end_sites=True)
    heights = sole_heights(motion, pos, feet, options.sole / unit)
    speeds = foot_speeds(pos[:, : len(motion.skeleton)], feet, motion.fps, vertical=True)
    flags = foot_contacts(heights, speeds, motion.fps, options, unit)
    return {side: [(a / motion.fps, b / motion.fps) for a, b in _runs(flags[:, f])] for f, side in enumerate(SIDES)}


def sidecar_path(motion_path: str | Path) -> Path:
    """``dance.markers.json`` beside ``dance.bvh`` (or any motion file)."""
    path = Path(motion_path)
    return path.with_name(path.stem + SIDECAR)


def write_markers(path: str | Path, markers: Markers, fps: float | None = None) -> None:
    """Write a ``.markers.json`` sidecar atomically (``fps``: the motion's frame rate, for tools that count frames)."""
    data = markers.to_dict()
    if fps is not None:
        data["fps"] = float(fps)
    lines = ",\n".join(f" {json.dumps(key)}: {json.dumps(value)}" for key, value in data.items())
    write_text(path, "{\n" + lines + "\n}\n")  # one key a line, its list on that line


def read_markers(path: str | Path) -> Markers:
    """A ``.markers.json`` sidecar; a missing or malformed file is one ``DataError`` line."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataError(f"{path}: markers file not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataError(f"{path}: not a markers JSON file: {exc}") from None
    return Markers.from_dict(data, str(path))
