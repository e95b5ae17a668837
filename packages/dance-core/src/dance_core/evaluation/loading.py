"""Folders of motion files to ``JointClip``s (motion formats + forward kinematics) with music beats."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np

from dance_core.checks import nonfinite_reason
from dance_core.data.files import audio_suffixes as readable_audio
from dance_core.data.files import motion_files, read_motion_file, read_texts
from dance_core.errors import DataError
from dance_core.evaluation import music as M
from dance_core.evaluation.clips import resampled, z_up_to_y_up
from dance_core.protocols import JointClip, MotionData
from dance_core.registry import Registry

NOMINAL_HEIGHT = 1.7  # metres, for skeletons of unknown units and implausible size
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "dm": 0.1, "in": 0.0254, "inch": 0.0254}
_POSITION_CHANNEL = re.compile(r"^(.+)[._]([xyzXYZ])$")


def metres_per_unit(skeleton) -> float:
    """Metres per skeleton unit: from its declared units, else from a plausible body height.

    Files whose units are unknown (BVH reports ``"file"``) are read as metres, centimetres,
    millimetres or inches, whichever makes the rest pose 1.0-2.5 m tall; failing that, the body is
    scaled to ``NOMINAL_HEIGHT`` (speed thresholds such as PFF's are in m/s).
    """
    units = str(getattr(skeleton, "units", "m")).lower()
    if units in UNITS:
        return UNITS[units]
    height = float(skeleton.height())
    if height <= 0:
        raise DataError(f"skeleton {getattr(skeleton, 'name', '')!r}: zero height; cannot infer its units")
    for factor in (1.0, 0.01, 0.001, 0.0254):
        if 1.0 <= height * factor <= 2.5:
            return factor
    return NOMINAL_HEIGHT / height


def joint_positions(data: MotionData, where: str) -> tuple[np.ndarray, list[str] | None, str]:
    """``(T, J, 3)`` positions in metres, joint names, and the up axis of a read motion.

    Skeletal motion (BVH, SMPL, ...) goes through forward kinematics; a frame array whose
    channels are joint coordinates (``name.x``, ``name.y``, ``name.z``) is reshaped as it is.
    """
    skeletal = getattr(data, "skeleton_motion", None)
    if skeletal is not None:
        skeleton = skeletal.skeleton
        positions = np.asarray(skeletal.positions(), dtype=np.float64) * metres_per_unit(skeleton)
        return positions, list(skeleton.names), str(getattr(skeleton, "up", "y")).lower()
    channels = list(data.channels or [])
    values = np.asarray(data.values, dtype=np.float64)
    matches = [_POSITION_CHANNEL.match(c) for c in channels]
    if channels and len(channels) % 3 == 0 and all(matches):
        triples = [matches[i : i + 3] for i in range(0, len(matches), 3)]
        if all(
            [m.group(2).lower() for m in t] == ["x", "y", "z"] and len({m.group(1) for m in t}) == 1 for t in triples
        ):
            names = [t[0].group(1) for t in triples]
            return values.reshape(len(values), -1, 3), names, "y"
    raise DataError(
        f"{where}: cannot get joint positions: the format gives no skeleton and the channels are not "
        f"joint coordinates (name.x, name.y, name.z)"
    )


def load_clips(
    folder: str | Path,
    registry: Registry,
    up: str | None = None,
    on_file: Callable[[Path], None] | None = None,
    suffixes: list[str] | None = None,
) -> list[JointClip]:
    """Every motion file of a folder as a Y-up ``JointClip`` named by its file stem.

    A sidecar ``NAME.texts`` beside ``NAME.ext`` (``start<TAB>end<TAB>sentence`` lines, as
    ``dance compose`` writes) puts its spans into ``meta["texts"]`` as ``(start, end, text)``.
    ``up`` overrides the up axis the format reports (``"y"`` or ``"z"``); ``on_file`` is called
    before each file is read (progress display); ``suffixes`` restricts the files read. A clip whose
    positions hold NaN or inf is kept with ``meta["unusable"]`` saying where; :func:`evaluate
    <dance_core.evaluation.report.evaluate>` leaves it out and names it in the report.
    """
    clips = []
    for path in motion_files(Path(folder), registry, suffixes):
        if on_file:
            on_file(path)
        data = read_motion_file(path, registry)
        positions, names, axis = joint_positions(data, str(path))
        axis = up or axis
        if axis not in ("y", "z"):
            raise DataError(f"{path}: up axis must be 'y' or 'z', got {axis!r}")
        if axis == "z":
            positions = z_up_to_y_up(positions)
        meta: dict = {"path": str(path)}
        reason = nonfinite_reason(positions, names)
        if reason is not None:
            meta["unusable"] = f"motion holds {reason}"
        sidecar = path.with_name(f"{path.stem}.texts")
        if sidecar.is_file():
            meta["texts"] = [(t.start, t.end, t.text) for t in read_texts(sidecar)]
        clips.append(JointClip(path.stem, positions, float(data.fps), names, meta=meta))
    return clips


def common_fps(clips: list[JointClip], fps: float | None = None) -> list[JointClip]:
    """Resample every clip to ``fps`` (default: the most common rate among the clips)."""
    target = fps or Counter(c.fps for c in clips).most_common(1)[0][0]
    return [resampled(c, target) for c in clips]


def attach_music(clips: list[JointClip], music_dir: str | Path, registry: Registry,
                 tracker: str = "flux") -> list[str]:
    """Set ``music_beats`` of every clip whose song is in ``music_dir`` (audio through ``tracker``);
    return notes on the sources."""
    folder = Path(music_dir)
    if not folder.is_dir():
        raise DataError(f"{folder}: not a folder of music")
    from dance_core.data.features import load_audio

    audio_suffixes = readable_audio(registry)
    cache: dict[Path, np.ndarray] = {}
    methods: Counter[str] = Counter()
    notes = []
    for clip in clips:
        song = M.find_song(folder, clip.name, audio_suffixes)
        if song is None:
            notes.append(f"music: no song for {clip.name} in {folder}")
            continue
        if song not in cache:
            if song.suffix == ".beats":
                cache[song], method = M.read_beats_file(song), "beat annotation files"
            else:
                cache[song], method = M.audio_beats(load_audio(song, registry), registry, tracker)
            methods[method] += 1
        clip.music_beats = cache[song]
        clip.meta["music"] = str(song)
        audio = song if song.suffix != ".beats" else M.find_audio(folder, song.stem, audio_suffixes)
        if audio is not None:
            clip.meta["audio"] = str(audio)
    notes += [f"music beats from {method} ({n} song(s))" for method, n in methods.items()]
    return notes
