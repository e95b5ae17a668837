"""What composition writes: each song's output set (its dances in every format, and its text spans), on the
beat and grounded."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from dance_core.atomic import OutputSet, set_complete
from dance_core.checkpoint import Checkpoint
from dance_core.checks import implausible_root, nonfinite_reason, refuse_same_names
from dance_core.compose.edits import Edits
from dance_core.compose.songs import Song
from dance_core.data.motion_info import MotionInfo
from dance_core.delivery import Delivery, dance_markers, deliver, motion_data, written_up
from dance_core.errors import DanceError, DataError
from dance_core.motion.markers import SIDECAR, write_markers
from dance_core.protocols import MotionData
from dance_core.recipe.schema import Recipe
from dance_core.registry import Registry


def output_targets(out: Path, stems: list[str], formats: list, texts: bool, markers: bool = False) -> list[Path]:
    """Every file one song's dances are written to (its output set), in write order."""
    targets = []
    for stem in stems:
        targets.extend(out / f"{stem}{format_suffix(entry)}" for entry, _ in formats)
        if texts:
            targets.append(out / f"{stem}.texts")
        if markers:
            targets.append(out / f"{stem}{SIDECAR}")
    return targets


def manifest_path(out: Path, song_path: str) -> Path:
    """The hidden file that records a song's committed output set (``.SONG.outputs.json``)."""
    return Path(out) / f".{Path(song_path).stem}.outputs.json"


def complete(targets: list[Path], manifest: Path) -> bool:
    """True when a song's output set was committed whole: its manifest (written after the last rename
    of the set, removed before the first) lists exactly ``targets`` and each is there at its recorded
    size. A set cut short (a failed rename during ``--overwrite``, a kill) or files replaced by hand
    are never taken as complete; a set written before manifests existed is composed again."""
    return set_complete(manifest, targets)


def write_song(
    song: Song, motion: np.ndarray, stems: list[str], out: Path, formats: list, ckpt: Checkpoint,
    recipe: Recipe, registry: Registry, delivery: Delivery | None = None, edits: Edits | None = None,
    sidecars: list[Path] | None = None,
) -> list[Path]:
    """Decode, finish (on the beat, grounded: :func:`finished`), deliver (onto a rig, at a frame rate, in
    units: :mod:`dance_core.delivery`) and write one song's dances ``(samples, frames, D)`` as one output
    set (every file or none, markers sidecars with ``compose.markers``); returns the motion files written
    and adds the sidecars written beside them (``.texts``, ``.markers.json``) to ``sidecars`` when given."""
    with OutputSet(manifest_path(out, song.path)) as files:
        for k, stem in enumerate(stems):
            values = ckpt.stats.motion.invert(motion[k, : song.n_frames])
            data = finished(ckpt.motion.decode(values, recipe.fps, registry), song, ckpt.motion, registry, recipe,
                            edits=edits)
            data = delivered(data, song, delivery, recipe, registry, stem)
            if recipe.compose.markers:
                write_markers(files.path(out / f"{stem}{SIDECAR}"), data.meta["markers"], data.fps)
            data.meta["audio_path"] = song.path
            data.meta["title"] = stem  # previews show the file's own name, not its temporary one
            up = delivery.up if delivery is not None else None
            for entry, fmt in formats:  # glb and previews Y up, bvh and npz Z up with compose.up z
                fmt.write(written_up(data, entry.name, up), str(files.path(out / f"{stem}{format_suffix(entry)}")))
            if song.texts:  # the spans beside the dance, for dance evaluate (MPD at text starts)
                lines = "".join(f"{t.start:.4f}\t{t.end:.4f}\t{' '.join(t.text.split())}\n" for t in song.texts)
                files.path(out / f"{stem}.texts").write_text(lines, encoding="utf-8")
        targets = files.targets()  # (the set is committed when the block ends)
    beside = [p for p in targets if p.suffix == ".texts" or p.name.endswith(SIDECAR)]
    if sidecars is not None:
        sidecars.extend(beside)
    return [p for p in targets if p not in beside]


def delivered(data: MotionData, song: Song, delivery: Delivery | None, recipe: Recipe, registry: Registry,
              where: str) -> MotionData:
    """A finished dance onto the rig, at the frame rate and in the units of ``delivery`` (its frame array
    then joint positions, as ``dance convert`` writes), with the song's markers in ``meta["markers"]``
    when ``compose.markers`` asks for them."""
    motion = data.skeleton_motion
    if motion is None:
        if delivery is not None and delivery.changes or recipe.compose.markers:
            raise DataError(f"{where}: the model's motion has no skeleton; compose.rig, output_fps, units, up and "
                            "markers need one")
        return data
    if delivery is not None and delivery.changes:
        motion, note = deliver(motion, delivery, where)
        meta = {**data.meta, "retarget": note} if note else dict(data.meta)
        data = motion_data(motion, meta)
    if recipe.compose.markers:
        from dance_core.compose.songs import beat_tracker_of

        tracker = beat_tracker_of(recipe, registry) or "flux"
        try:
            data.meta["markers"] = dance_markers(motion, registry, song.path, tracker=tracker, start=song.start)
        except DataError:  # a song with too few beats: its dance's foot contacts only
            data.meta["markers"] = dance_markers(motion, registry)
    return data


def finished(data: MotionData, song: Song, info: MotionInfo, registry: Registry, recipe: Recipe,
             ground: bool | None = None, edits: Edits | None = None) -> MotionData:
    """A decoded skeletal dance as it is written: on the floor with its feet pinned in contact (``ground``,
    default ``compose.ground``), then its accents moved onto the song's beats when the song carries them
    (``compose.beat_align``, :mod:`dance_core.motion.beat_align`; a time warp keeps planted feet where
    they are; onto a rig a dance the warp moved is grounded again, so that grounding it once more, as the
    rig's delivery does, changes it by little); its frame array encoded again from the
    changed motion. What each step did is in
    ``data.meta``. ``edits`` (:mod:`dance_core.compose.edits`): kept parts and facing before grounding,
    keyframes and the loop after the beat alignment; a ``--from`` dance has its spans replaced by this
    dance's (grounded), every other frame kept as it was."""
    from dance_core.motion.beat_align import align_to_beats
    from dance_core.motion.grounding import ground as put_on_floor

    check_plausible(data, song, recipe)
    motion = data.skeleton_motion
    if motion is None:
        return data
    if edits is not None and edits.source is not None:
        return _spliced(data, motion, edits, info, registry, recipe.compose.ground if ground is None else ground)
    changed = edits is not None and edits.any
    if changed:
        motion = edits.before_ground(motion)
    grounded = recipe.compose.ground if ground is None else ground
    if grounded:
        motion, report = put_on_floor(motion)
        data.meta["grounding"] = report.summary()
        changed = changed or not report.skipped
    if song.beats is not None:  # after grounding: the accents of the feet as they will be seen
        motion, alignment = align_to_beats(motion, song.beats)
        data.meta["beat_align"] = alignment.summary()
        changed = changed or alignment.moved > 0
        # onto a rig, whose delivery grounds again, the warped dance is pinned again first, so that second
        # grounding keeps it (grounding twice keeps a grounded dance); not otherwise: a second pass reads
        # low hops (under the 8-cm release height) as contacts and flattens them
        if grounded and alignment.moved > 0 and recipe.compose.rig:
            motion, _ = put_on_floor(motion)
    if edits is not None:
        motion = edits.after_ground(motion)
    if not changed:
        return data
    rep = info.build_representation(registry)
    return replace(data, values=rep.encode(motion).astype(data.values.dtype), skeleton_motion=motion)


def check_plausible(data: MotionData, song: Song, recipe: Recipe) -> None:
    """A generated dance that holds NaN or inf, or a skeletal one whose root leaves a plausible range
    (``implausible_root``: 50 m from the origin, 20 m/s; dances of joint positions, which may be image
    keypoints in pixels, are only checked for finite values), is an error naming the recipe, its model and
    the song: the model failed, and the song's dances are not written as a success."""
    bad = np.flatnonzero((~np.isfinite(np.asarray(data.values))).reshape(len(data.values), -1).any(axis=1))
    reason = f"its frames hold NaN or inf from frame {bad[0]} ({len(bad)} frames)" if len(bad) else None
    motion = data.skeleton_motion
    if reason is None and motion is not None:
        rotations = motion.rotations
        if rotations is not None and not np.isfinite(rotations).all():
            reason = f"its joint rotations hold {nonfinite_reason(rotations)}"
        elif rotations is not None:  # a body in metres (or cm); joint positions may be image keypoints in pixels
            reason = implausible_root(motion.root * (0.01 if motion.skeleton.units == "cm" else 1.0), motion.fps)
    if reason is not None:
        raise DataError(f"{song.path or song.name}: the dance generated by recipe {recipe.origin} (head "
                        f"{recipe.model.head.plugin!r}) is not a plausible dance: {reason}; nothing is written for "
                        "this song (is the checkpoint trained, and for this recipe?)")


def _spliced(data: MotionData, take, edits: Edits, info: MotionInfo, registry: Registry, ground: bool) -> MotionData:
    """The ``--from`` dance with its spans from ``take`` (:func:`dance_core.motion.splice.splice`)."""
    from dance_core.motion.grounding import ground as put_on_floor
    from dance_core.motion.splice import splice

    if ground:
        take, _ = put_on_floor(take)
    fps = edits.source.fps
    spans = [(int(round(a * fps)), int(round(b * fps))) for a, b in edits.spans]
    motion = splice(edits.source, take, spans)
    data.meta["regenerated"] = ", ".join(f"{a:g}-{b:g} s" for a, b in edits.spans)
    if edits.source_path is not None:  # the kept frames' lines of a BVH source, written as they were
        kept = np.ones(motion.n_frames, bool)
        for a, b in spans:
            kept[a:b] = False
        data.meta["bvh_kept"] = (edits.source_path, kept)
    rep = info.build_representation(registry)
    return replace(data, values=rep.encode(motion).astype(data.values.dtype), skeleton_motion=motion)


def format_suffix(entry) -> str:
    """The suffix a motion format writes (its first registered suffix, else ``.NAME``)."""
    return (entry.suffixes or ("." + entry.name,))[0]


def output_stems(paths: list[str], samples: int) -> list[list[str]]:
    """Per song, the file stems of its samples; two songs that would write the same files are an error."""
    try:
        refuse_same_names(paths)
    except DanceError as exc:
        raise DataError(str(exc)) from None
    names = [Path(path).stem for path in paths]
    return [[name] if samples == 1 else [f"{name}-{k}" for k in range(samples)] for name in names]
