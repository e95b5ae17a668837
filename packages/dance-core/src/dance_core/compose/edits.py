"""Edits of a composed dance, as an animator asks for them: keyframes, body parts kept from a given motion,
facing the camera, a turning-speed limit, a loop, and spans regenerated in a given dance.

:func:`plan_edits` reads and checks every file the edits name, on the model's skeleton, before any dance
is generated (a pose on another skeleton is retargeted when its joints can be mapped, else one line);
:meth:`Edits.check_song` checks times against a song's length before its generation. What a model
generates is steered where the model can take it (:meth:`Edits.forced`: the frames of a ``--from``
dance outside the regenerated spans, and a kept part's channels, are fed back as the dance's own past);
the rest is done on the decoded motion (:mod:`dance_core.motion.keyframes`, ``parts``, ``facing``,
``loop``, ``splice``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from dance_core.checkpoint import Checkpoint
from dance_core.errors import DataError, RecipeError
from dance_core.motion.keyframes import Keyframe, check_keyframes, hit, keyframe_of
from dance_core.motion.motion import Motion
from dance_core.motion.parts import check_part, keep_part, part_joints
from dance_core.recipe.schema import Recipe
from dance_core.registry import Registry

_KEYFRAME = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*=\s*(.+?)(?::([0-9]+))?\s*$")
_SPAN = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*-\s*([0-9]*\.?[0-9]+)\s*$")


def parse_keyframe(spec: str, where: str) -> tuple[float, str, int]:
    """``"12.0=pose.bvh[:FRAME]"`` as (seconds, file, frame); anything else is one line naming ``where``."""
    m = _KEYFRAME.match(spec)
    if not m:
        raise RecipeError(f"{where} {spec!r}: expected SECONDS=POSE_FILE[:FRAME], e.g. 12.0=pose.bvh:30")
    return float(m.group(1)), m.group(2), int(m.group(3) or 0)


def parse_span(spec: str, where: str) -> tuple[float, float]:
    """``"20-30"`` as (start, end) seconds, start before end; else one line naming ``where``."""
    m = _SPAN.match(spec)
    if not m or float(m.group(1)) >= float(m.group(2)):
        raise RecipeError(f"{where} {spec!r}: expected START-END in seconds with START < END, e.g. 20-30")
    return float(m.group(1)), float(m.group(2))


def check_spans(spans: list[tuple[float, float]], where: str) -> list[tuple[float, float]]:
    """The spans by start; two that overlap are one line."""
    ordered = sorted(spans)
    for (a0, a1), (b0, b1) in zip(ordered, ordered[1:], strict=False):
        if b0 < a1:
            raise RecipeError(f"{where}: spans {a0:g}-{a1:g} and {b0:g}-{b1:g} overlap")
    return ordered


@dataclass
class Edits:
    """Every edit of one composition, its files read onto the model's skeleton at its frame rate."""

    keyframes: list[Keyframe] = field(default_factory=list)
    keep: dict[str, Motion] = field(default_factory=dict)
    face: str = "free"
    max_turn: float | None = None
    loop: bool = False
    source: Motion | None = None  # the --from dance
    source_path: str | None = None  # its file, whose frame lines a BVH output keeps outside the spans
    spans: list[tuple[float, float]] = field(default_factory=list)
    where: dict[str, str] = field(default_factory=dict)

    @property
    def any(self) -> bool:
        """True when there is an edit to make."""
        return bool(self.keyframes or self.keep or self.face != "free" or self.max_turn or self.loop
                    or self.source is not None)

    def check_song(self, n_frames: int, fps: float, where: str) -> None:
        """Keyframes and spans inside a song of ``n_frames`` frames (one line each, before generating)."""
        duration = n_frames / fps
        check_keyframes(self.keyframes, duration)
        for start, end in self.spans:
            if end > duration + 0.5 / fps:
                raise DataError(f"{where}: {self.where['regenerate']} {start:g}-{end:g} ends past the dance's "
                                f"{duration:.2f} s")

    def forced(self, ckpt: Checkpoint, registry: Registry, n_frames: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Normalized frames ``(n, D)`` and a mask ``(n, D)`` of what generation must take as given: the
        ``--from`` dance outside its spans, the kept parts' channels; None when nothing is."""
        from dance_core.delivery import motion_data

        if self.source is None and not self.keep:
            return None
        dim = ckpt.motion.dim
        values, mask = np.zeros((n_frames, dim), np.float32), np.zeros((n_frames, dim), bool)

        def encoded(motion: Motion) -> np.ndarray:
            data = ckpt.motion.encode(motion_data(motion), registry)
            return ckpt.stats.motion.apply(data.values)[:n_frames]

        channels = list(ckpt.motion.channels or ())
        for part, motion in self.keep.items():
            from dance_core.motion.parts import WITH_PATH, fitted

            enc = encoded(fitted(motion, n_frames))
            names = {motion.skeleton.names[j] for j in part_joints(motion, part)}
            cols = [i for i, c in enumerate(channels) if c.split(".")[0] in names
                    or (part in WITH_PATH and c.startswith("root."))]
            values[: len(enc), cols], mask[: len(enc), cols] = enc[:, cols], True
        if self.source is not None:
            enc = encoded(self.source)
            rows = np.ones(len(enc), bool)
            for start, end in self.spans:
                rows[int(round(start * ckpt.motion.fps)) : int(round(end * ckpt.motion.fps))] = False
            values[: len(enc)][rows], mask[: len(enc)][rows] = enc[rows], True
        return values, mask

    def before_ground(self, motion: Motion) -> Motion:
        """Kept parts and facing, before the dance is put on the floor."""
        from dance_core.motion.facing import face

        for part, source in self.keep.items():
            motion = keep_part(motion, source, part, self.where.get(part, part))
        if self.face != "free" or self.max_turn:
            motion = face(motion, self.face, self.max_turn)
        return motion

    def after_ground(self, motion: Motion) -> Motion:
        """Keyframes and the loop, on the dance as it will be written (grounded, on the beat)."""
        from dance_core.motion.loop import looped

        if self.keyframes:
            motion = hit(motion, self.keyframes)
        if self.loop:
            motion = looped(motion)
        return motion


def _read_on(path: str, registry: Registry, ckpt: Checkpoint, formats, where: str, resample: bool = True) -> Motion:
    """A motion file on the model's skeleton (at its frame rate unless ``resample`` is False): conformed
    when its joints are the model's, retargeted when a joint map knows them, else one line."""
    from dance_core.checks import check_input_file
    from dance_core.data.files import read_motion_file

    check_input_file(path, where, "motion file")
    motion = read_motion_file(path, registry, formats=formats).skeleton_motion
    if motion is None or motion.rotations is None:
        raise DataError(f"{where} {path}: needs a skeletal motion with joint rotations")
    skeleton = ckpt.motion.skeleton
    if sorted(motion.skeleton.names) != sorted(skeleton.names):
        from dance_core.motion.retarget import retarget

        try:
            motion, _ = retarget(motion, skeleton, where=path)
        except DataError as exc:
            raise DataError(f"{where} {path}: its skeleton is not the model's ({skeleton.name}) and cannot be "
                            f"mapped onto it: {exc}") from None
    motion = motion.conformed(skeleton, path)
    return motion.resample(ckpt.motion.fps) if resample else motion


def plan_edits(recipe: Recipe, ckpt: Checkpoint, registry: Registry, labels: dict[str, str]) -> Edits:
    """The recipe's edits (``compose.keyframes``, ``keep_parts``, ``face``, ``max_turn``, ``loop``,
    ``from_motion`` and ``regenerate``) with their files read onto the model's skeleton; ``labels`` names
    the option or field each came from, for one-line errors."""
    from dance_core.compose.inputs import beside_recipe

    c = recipe.compose
    edits = Edits(face=c.face, max_turn=c.max_turn, loop=c.loop, where=dict(labels))
    wanted = bool(c.keyframes or c.keep_parts or c.face != "free" or c.max_turn or c.loop or c.from_motion)
    if wanted and (ckpt.motion.skeleton is None or ckpt.motion.representation is None):
        raise RecipeError(f"{labels['keyframes']}...: edits need a model of skeletal motion; {ckpt.path} makes "
                          "feature frames")
    if c.regenerate and not c.from_motion:
        raise RecipeError(f"{labels['regenerate']}: needs the dance to edit ({labels['from_motion']} DANCE)")
    spans = check_spans([parse_span(s, labels["regenerate"]) for s in c.regenerate], labels["regenerate"])
    if c.from_motion and (c.keyframes or c.keep_parts or c.face != "free" or c.max_turn or c.loop):
        raise RecipeError(f"{labels['from_motion']}: regenerating spans keeps every other frame as it is; make the "
                          "other edits (keyframes, kept parts, facing, loop) in a run of their own")
    if c.from_motion and not spans:
        raise RecipeError(f"{labels['from_motion']}: give the spans to regenerate ({labels['regenerate']} A-B)")
    for part in c.keep_parts:
        check_part(part, labels["keep_parts"])
    parsed = [parse_keyframe(spec, labels["keyframes"]) for spec in c.keyframes]
    for part, path in c.keep_parts.items():
        label = f"{labels['keep_parts']} {part}"
        edits.keep[part] = _read_on(beside_recipe(path, recipe), registry, ckpt, recipe.format_options, label)
        edits.where[part] = f"{label}={path}"
    for seconds, path, frame in parsed:
        label = f"{labels['keyframes']} {seconds:g}={path}"
        motion = _read_on(beside_recipe(path, recipe), registry, ckpt, recipe.format_options, label, False)
        edits.keyframes.append(keyframe_of(motion, seconds, frame, label))
    check_keyframes(edits.keyframes, float("inf"))  # two too close: before any song is read
    if c.from_motion:
        edits.source_path = str(beside_recipe(c.from_motion, recipe))
        edits.source = _read_on(edits.source_path, registry, ckpt, recipe.format_options, labels["from_motion"])
        edits.spans = spans
    return edits


def limits(model, edits: Edits, where: str) -> None:
    """One line when the model's family cannot take given frames (its head rewrites the whole motion
    after generating it, as TM2D's token decoder does) and ``--from``/``--regenerate`` needs it to."""
    if edits.source is not None and getattr(model.head, "rewrites_motion", False):
        raise RecipeError(f"{where}: the {type(model.head).__name__} head decodes the whole dance at the end, so "
                          "it cannot continue given frames; --regenerate needs an autoregressive family (Transflower "
                          "default, core-dance, MoGlow, DanceRevolution)")

