"""BVH read/write: any channel order, End Sites, depth-first frame layout, unit scale, continuous Euler.

The root's position channels hold its absolute position (what Blender, bvhio and other tools read);
its OFFSET is the skeleton's rest offset. Files dance wrote before held the root's position relative
to that OFFSET: the reader's ``root="auto"`` tells them apart (see :func:`reads_relative`).
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.atomic import atomic_path
from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import euler_to_quat, quat_conj, quat_mul, quat_rotate, quat_to_euler
from dance_core.motion.skeleton import Skeleton
from dance_core.protocols import MotionData

POSITIONS = ("Xposition", "Yposition", "Zposition")
ROTATIONS = ("Xrotation", "Yrotation", "Zrotation")
#: how the root's position channels are read: ``auto`` chooses between the other two per file
ROOT_MODES = ("auto", "absolute", "relative")
#: "on the floor": the median lowest point within this fraction of the skeleton's height of 0
FLOOR_TOLERANCE = 0.05
#: at most this many evenly spaced frames are posed to decide the ``auto`` reading
AUTO_FRAMES = 2000


def _fps(frame_time: float) -> float:
    fps = 1.0 / frame_time
    return float(round(fps)) if abs(fps - round(fps)) < 1e-3 * fps else fps


class _Parser:
    """A small recursive-descent parser over whitespace tokens of the HIERARCHY section; ``lines``
    holds each token's line number, for errors."""

    def __init__(self, path: Path, tokens: list[str], lines: list[int] | None = None):
        self.path, self.tokens, self.i = path, tokens, 0
        self.lines = lines if lines is not None else [0] * len(tokens)
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[tuple[str, ...]] = []
        self.end_sites: dict[int, np.ndarray] = {}
        self.joint_lines: dict[int, int] = {}

    def fail(self, what: str):
        """Raise a one-line error naming the file and the line of the token at fault."""
        at = min(max(self.i - 1, 0), len(self.tokens) - 1)
        line = self.lines[at] if self.tokens else 0
        raise DataError(f"{self.path}:{line}: BVH HIERARCHY: {what}")

    def take(self, expected: str | None = None) -> str:
        """The next token (which must be ``expected``, case-insensitively, when given)."""
        if self.i >= len(self.tokens):
            self.fail(f"unexpected end, expected {expected or 'more'}")
        tok = self.tokens[self.i]
        self.i += 1
        if expected is not None and tok.upper() != expected.upper():
            self.fail(f"expected {expected!r}, found {tok!r}")
        return tok

    def numbers(self, n: int) -> list[float]:
        """The next ``n`` tokens as finite numbers."""
        out = []
        for _ in range(n):
            tok = self.take()
            try:
                value = float(tok)
            except ValueError:
                self.fail(f"a number was expected, found {tok!r}")
            if not np.isfinite(value):
                self.fail(f"{tok!r} is not a finite number")
            out.append(value)
        return out

    def joint(self, parent: int) -> None:
        """One joint (name, offset, channels, children and End Site) and everything below it."""
        name = self.take()
        self.joint_lines[len(self.names)] = self.lines[self.i - 1]
        if name.upper() == "SITE":  # "End Site" reached through a misplaced keyword
            self.fail("End Site outside a joint")
        index = len(self.names)
        self.names.append(name)
        self.parents.append(parent)
        self.take("{")
        self.take("OFFSET")
        self.offsets.append(self.numbers(3))
        chans: tuple[str, ...] = ()
        if self.i < len(self.tokens) and self.tokens[self.i].upper() == "CHANNELS":
            self.take()
            try:
                n = int(self.take())
            except ValueError:
                self.fail("CHANNELS count is not an integer")
            chans = tuple(self.take() for _ in range(n))
            bad = [c for c in chans if c not in POSITIONS + ROTATIONS]
            if bad:
                self.fail(f"joint {name!r}: unknown channel {bad[0]!r}")
        self.channels.append(chans)
        while True:
            tok = self.take()
            if tok == "}":
                return
            if tok.upper() == "JOINT":
                self.joint(index)
            elif tok.upper() == "END":
                self.take("Site")
                self.take("{")
                self.take("OFFSET")
                self.end_sites[index] = np.array(self.numbers(3))
                self.take("}")
            else:
                self.fail(f"unexpected {tok!r} in joint {name!r}")


def _motion_line(lines: list[str]) -> int | None:
    for i, line in enumerate(lines):
        if line.strip().upper() == "MOTION":
            return i
    return None


def _header_value(path: Path, lines: list[str], i: int, key: str, kind: type) -> float:
    if i >= len(lines):
        raise DataError(f"{path}:{i + 1}: BVH MOTION: file ends before the {key!r} line")
    name, sep, value = lines[i].partition(":")
    if not sep or " ".join(name.split()).lower() != key.lower():
        raise DataError(f"{path}:{i + 1}: BVH MOTION: expected '{key}: ...', found {lines[i].strip()[:40]!r}")
    text = value.strip()
    if len(text) > 40:  # no frame count or frame time is written with more digits
        raise DataError(f"{path}:{i + 1}: BVH MOTION: {key} {text[:20]!r}... is not a plausible number")
    try:
        number = kind(text)
    except ValueError:
        raise DataError(f"{path}:{i + 1}: BVH MOTION: {key} {text!r} is not a number") from None
    if not math.isfinite(number):
        raise DataError(f"{path}:{i + 1}: BVH MOTION: {key} {value.strip()!r} is not a finite number")
    return number


def _frame_rows(path: Path, lines: list[str], first: int, n_frames: int, n_ch: int) -> np.ndarray:
    """``n_frames`` rows of ``n_ch`` finite numbers from line index ``first`` on (blank lines skipped);
    an error names the line at fault."""
    rows, numbers = [], []
    for i in range(first, len(lines)):
        if len(rows) == n_frames:
            break
        if not lines[i].strip():
            continue
        rows.append(i)
        numbers.append(lines[i].split())
    if len(rows) < n_frames:
        raise DataError(f"{path}:{len(lines)}: BVH MOTION: {n_frames} frames of {n_ch} channels declared, "
                        f"found {len(rows)} (the file ends early: truncated?)")
    for i, row in zip(rows, numbers, strict=True):
        if len(row) != n_ch:
            raise DataError(f"{path}:{i + 1}: BVH MOTION: frame {rows.index(i)} has {len(row)} values, "
                            f"the hierarchy declares {n_ch} channels")
    try:
        values = np.array(numbers, dtype=np.float64).reshape(n_frames, n_ch)
    except ValueError:
        for i, row in zip(rows, numbers, strict=True):
            for tok in row:
                try:
                    float(tok)
                except ValueError:
                    raise DataError(f"{path}:{i + 1}: BVH MOTION: {tok[:20]!r} is not a number") from None
        raise
    bad = ~np.isfinite(values)
    if bad.any():
        frame, col = (int(x) for x in np.argwhere(bad)[0])
        raise DataError(f"{path}:{rows[frame] + 1}: BVH MOTION: frame {frame} holds {numbers[frame][col]!r} "
                        f"(value {col + 1}); frame data must be finite numbers")
    return values


def parse_bvh(path: str | Path, scale: float = 1.0) -> tuple[Skeleton, np.ndarray, list[str], float]:
    """Skeleton, raw frame array ``(T, C)``, channel names and fps of a BVH file; a malformed,
    truncated or non-finite file is a one-line error naming the file and line (``path:LINE: ...``)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig", errors="replace")  # a byte-order mark is no error
    except FileNotFoundError:
        raise DataError(f"{path}: motion file not found") from None
    except IsADirectoryError:
        raise DataError(f"{path}: is a folder, not a BVH file") from None
    lines = text.splitlines()
    at = _motion_line(lines)
    if at is None:
        raise DataError(f"{path}: not a BVH file (no MOTION section)")
    tokens, token_lines = [], []
    for i, line in enumerate(lines[:at]):
        words = line.split()
        tokens += words
        token_lines += [i + 1] * len(words)
    if not tokens or tokens[0].upper() != "HIERARCHY":
        raise DataError(f"{path}: not a BVH file (no HIERARCHY)")
    p = _Parser(path, tokens, token_lines)
    p.i = 1
    p.take("ROOT")
    p.joint(-1)
    if p.i < len(tokens):
        p.i += 1
        p.fail(f"unexpected {tokens[p.i - 1]!r} after the root joint")
    first = at + 1
    while first < len(lines) and not lines[first].strip():
        first += 1
    n_frames = int(_header_value(path, lines, first, "Frames", int))
    frame_time = _header_value(path, lines, first + 1, "Frame Time", float)
    if n_frames < 0:
        raise DataError(f"{path}:{first + 1}: BVH MOTION: negative frame count {n_frames}")
    if frame_time <= 0:
        raise DataError(f"{path}:{first + 2}: BVH MOTION: frame time must be positive, got {frame_time:g}")
    n_ch = sum(len(c) for c in p.channels)
    if n_frames > len(lines) - first - 2:  # before any frame is looked at: every frame is a line
        raise DataError(f"{path}:{first + 1}: BVH MOTION: {n_frames} frames of {n_ch} channels declared, found "
                        f"{max(len(lines) - first - 2, 0)} lines after the header (the file ends early: truncated?)")
    values = _frame_rows(path, lines, first + 2, n_frames, n_ch)
    skel = Skeleton(p.names, p.parents, np.array(p.offsets) * scale, p.channels,
                    {k: v * scale for k, v in p.end_sites.items()}, name=path.stem,
                    units="file" if scale == 1.0 else f"file x {scale:g}", lines=p.joint_lines, source=str(path))
    names = [f"{p.names[j]}.{c}" for j in range(len(p.names)) for c in p.channels[j]]
    return skel, values, names, _fps(frame_time)


def _up_axis(skel: Skeleton) -> int:
    return 2 if skel.up == "z" else 1


def _rest_extent(skel: Skeleton, axis: int) -> float:
    """Extent of the rest pose (End Sites included) along ``axis``."""
    pos = skel.rest_positions()
    pts = np.concatenate([pos] + [pos[j][None] + off for j, off in skel.end_sites.items()])
    return float(np.ptp(pts[:, axis]))


def reads_relative(motion: Motion, shift: np.ndarray) -> bool:
    """The ``auto`` rule: whether a file's root position channels are relative to the root OFFSET
    (files dance wrote before) rather than absolute (the BVH convention, read by default).

    ``motion`` is the file read absolute and ``shift`` what a relative reading adds to its root (the
    root OFFSET on the axes that have a position channel). Relative is chosen only when the figure
    stands on the floor when read relative and not when read absolute: the median over frames of the
    lowest joint or End Site height (along the skeleton's up axis) is within ``FLOOR_TOLERANCE`` of
    the rest pose's height of 0 in the one reading and not in the other. A zero OFFSET makes both
    readings equal; an OFFSET with no up component cannot be told apart this way and reads absolute.
    """
    axis = _up_axis(motion.skeleton)
    if shift[axis] == 0.0 or motion.n_frames == 0 or motion.rotations is None:
        return False
    tol = FLOOR_TOLERANCE * _rest_extent(motion.skeleton, axis)
    step = max(1, -(-motion.n_frames // AUTO_FRAMES))
    sample = Motion(motion.skeleton, motion.fps, motion.root[::step], motion.rotations[::step])
    lowest = float(np.median(sample.positions(end_sites=True)[..., axis].min(axis=1)))
    return abs(lowest + shift[axis]) <= tol < abs(lowest)


def frames_to_motion(skel: Skeleton, values: np.ndarray, fps: float, scale: float = 1.0, where: str = "",
                     root: str = "absolute") -> Motion:
    """Raw BVH frame rows to a :class:`Motion` (position channels scaled by ``scale``). ``root`` reads
    the root's position channels as its absolute position (``"absolute"``, the BVH convention), as
    an offset from its OFFSET (``"relative"``, files dance wrote before), or picks one per file by
    :func:`reads_relative` (``"auto"``); a root without position channels stays at its OFFSET."""
    if root not in ROOT_MODES:
        raise DataError(f"{where}: BVH root reading {root!r} is not one of {', '.join(ROOT_MODES)}")
    t = len(values)
    rotations = np.zeros((t, len(skel), 4))
    rotations[..., 3] = 1.0
    trans = np.repeat(skel.offsets[:1], t, axis=0)
    shift = np.zeros(3)  # what reading the root relative to its OFFSET adds
    col = 0
    offsets = skel.offsets.copy()
    for j, chans in enumerate(skel.channels):
        block = values[:, col : col + len(chans)]
        col += len(chans)
        rot = [c[0] for c in chans if c in ROTATIONS]
        if rot:
            cols = [k for k, c in enumerate(chans) if c in ROTATIONS]
            rotations[:, j] = euler_to_quat(block[:, cols], "".join(rot))
        pos = [(k, POSITIONS.index(c)) for k, c in enumerate(chans) if c in POSITIONS]
        if pos and j == 0:
            for k, axis in pos:
                trans[:, axis] = block[:, k] * scale
                shift[axis] = skel.offsets[0, axis]
        elif pos:
            for k, axis in pos:
                if np.ptp(block[:, k]) > 1e-6:
                    raise DataError(f"{where}: joint {skel.names[j]!r} has animated translation; "
                                    "only the root may move")
                offsets[j, axis] = block[0, k] * scale
    if not np.array_equal(offsets, skel.offsets):
        skel.offsets = offsets
    motion = Motion(skel, fps, trans, rotations)
    if root == "relative" or (root == "auto" and reads_relative(motion, shift)):
        motion = Motion(skel, fps, trans + shift, rotations)
    return motion


def dfs_order(skel: Skeleton) -> list[int]:
    """Joints in depth-first order (children in index order): BVH's hierarchy and frame layout."""
    order: list[int] = []
    stack = [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(skel.children(j)))
    return order


def written_end_sites(skel: Skeleton) -> dict[int, np.ndarray]:
    """The End Sites a BVH file of ``skel`` gets: the skeleton's own, and for every other leaf joint one
    that continues its bone (parent to leaf, or the nearest non-zero bone above it) by half that
    bone's length, at least 1% of the skeleton's size, so that no imported bone has zero length. The
    skeleton itself is left as it is."""
    ends = dict(skel.end_sites)
    rest = skel.rest_positions()
    size = float(np.ptp(rest, axis=0).max()) if len(skel) > 1 else 0.0
    least = 0.01 * size if size > 0 else 0.01
    for j in range(len(skel)):
        if j in ends or skel.children(j):
            continue
        k = j
        while k > 0 and np.linalg.norm(skel.offsets[k]) <= 1e-9:
            k = skel.parents[k]
        bone = skel.offsets[k] if k > 0 else np.eye(3)[_up_axis(skel)] * 2 * least
        length = float(np.linalg.norm(bone))
        ends[j] = bone / length * max(0.5 * length, least)
    return ends


def _writer_channels(skel: Skeleton, j: int) -> tuple[str, ...]:
    chans = tuple(c for c in skel.channels[j] if c in ROTATIONS) or ("Zrotation", "Xrotation", "Yrotation")
    return (POSITIONS + chans) if j == 0 else chans


def unsigned_zeros(values: np.ndarray, precision: int) -> np.ndarray:
    """``values`` with every number that prints as zero at ``precision`` decimals made ``+0.0``, so that
    the text never holds ``-0.000000`` (a -0.0, or a tiny negative number, where the same pose read and
    written again may give +0.0: the kept frames of an edited dance are then the same bytes)."""
    values = np.asarray(values, np.float64)
    return np.where(np.round(values, precision) == 0.0, 0.0, values)


def motion_to_bvh_text(motion: Motion, scale: float = 1.0, precision: int = 6) -> str:
    """BVH text of a motion (``scale`` multiplies lengths on the way out): the root's OFFSET is its rest
    offset and its position channels its absolute position; every leaf joint has an End Site
    (:func:`written_end_sites`). No number is printed as a negative zero (:func:`unsigned_zeros`)."""
    if motion.rotations is None:
        raise DataError("BVH needs joint rotations; this motion only has joint positions")
    skel = motion.skeleton
    order = dfs_order(skel)
    ends = written_end_sites(skel)
    out = ["HIERARCHY"]
    depth_of = {0: 0}

    def emit(j: int) -> None:
        d = depth_of[j]
        pad = "\t" * d
        kw = "ROOT" if j == 0 else "JOINT"
        out.append(f"{pad}{kw} {skel.names[j]}")
        out.append(f"{pad}{{")
        off = unsigned_zeros(skel.offsets[j] * scale, precision)
        out.append(f"{pad}\tOFFSET {off[0]:.{precision}f} {off[1]:.{precision}f} {off[2]:.{precision}f}")
        chans = _writer_channels(skel, j)
        out.append(f"{pad}\tCHANNELS {len(chans)} {' '.join(chans)}")
        for c in skel.children(j):
            depth_of[c] = d + 1
            emit(c)
        if j in ends:
            e = unsigned_zeros(ends[j] * scale, precision)
            out.extend([f"{pad}\tEnd Site", f"{pad}\t{{",
                        f"{pad}\t\tOFFSET {e[0]:.{precision}f} {e[1]:.{precision}f} {e[2]:.{precision}f}",
                        f"{pad}\t}}"])
        out.append(f"{pad}}}")

    emit(0)
    orders = {j: "".join(c[0] for c in _writer_channels(skel, j) if c in ROTATIONS) for j in order}
    euler = {}
    for rot_order in set(orders.values()):  # one vectorized conversion per rotation order
        group = [j for j in order if orders[j] == rot_order]
        for j, e in zip(group, np.moveaxis(quat_to_euler(motion.rotations[:, group], rot_order), 1, 0), strict=True):
            euler[j] = e
    cols = [motion.root * scale] + [euler[j] for j in order]
    frames = unsigned_zeros(np.concatenate(cols, axis=1), precision)
    out += ["MOTION", f"Frames: {len(frames)}", f"Frame Time: {1.0 / motion.fps:.8f}"]
    buf = io.StringIO()
    np.savetxt(buf, frames, fmt=f"%.{precision}f", delimiter=" ")
    return "\n".join(out) + "\n" + buf.getvalue()


def kept_lines(text: str, source: Path, kept: np.ndarray) -> str:
    """``text`` (BVH) with the frame lines marked ``kept`` taken from the BVH file ``source``, when its
    hierarchy and frame count are ``text``'s (else ``text`` as it is)."""
    try:
        original = source.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError):
        return text
    ours, theirs = text.split("\n"), original.split("\n")
    if "MOTION" not in ours or "MOTION" not in theirs:
        return text
    head, their_head = ours.index("MOTION"), theirs.index("MOTION")
    first = head + 3  # MOTION, Frames:, Frame Time:, then one line per frame
    n = len(kept)
    if (ours[:first] != theirs[:their_head + 3] or len(ours) < first + n or len(theirs) < their_head + 3 + n):
        return text
    for k in np.flatnonzero(kept):
        ours[first + k] = theirs[their_head + 3 + k]
    return "\n".join(ours)


#: the rotation taking a Z-up world to our Y-up one (-90 degrees about X)
Z_TO_Y_UP = np.array([-np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)])


def reoriented(motion: Motion, q: np.ndarray, up: str | None = None) -> Motion:
    """The motion expressed in a world turned by quaternion ``q``: a change of basis, so rest offsets
    and End Sites turn with it and every local rotation becomes ``q r q^-1`` (the rest pose stands
    up in the new world, and world positions are ``q`` applied to the old ones; a motion of joint
    positions has them turned). ``up`` is the new world's up axis (default: the skeleton's own)."""
    from dataclasses import replace

    skel = motion.skeleton
    turned = Skeleton(list(skel.names), list(skel.parents), quat_rotate(q, skel.offsets), list(skel.channels),
                      {k: quat_rotate(q, v) for k, v in skel.end_sites.items()}, skel.units,
                      up or skel.up, skel.name)
    rot = None if motion.rotations is None else quat_mul(quat_mul(q, motion.rotations), quat_conj(q))
    points = None if motion.joint_positions is None else quat_rotate(q, motion.joint_positions)
    return replace(motion, skeleton=turned, root=quat_rotate(q, motion.root), rotations=rot, joint_positions=points)


class BvhFormat:
    """The ``bvh`` motion format; ``scale`` converts file units on read (and back on write),
    ``up="z"`` turns Z-up files into our Y-up convention (and back on write), and ``root`` says how
    the root's position channels are read: ``"absolute"`` (the BVH convention, what we write),
    ``"relative"`` to the root OFFSET (files dance wrote before), or ``"auto"`` (the default):
    relative only when the figure stands on the floor read that way and not read absolute
    (:func:`reads_relative`)."""

    def __init__(self, scale: float = 1.0, precision: int = 6, up: str = "y", root: str = "auto"):
        if root not in ROOT_MODES:
            raise DataError(f"bvh format: root must be one of {', '.join(ROOT_MODES)}, not {root!r}")
        self.scale = scale
        self.precision = precision
        self.up = up
        self.root = root

    def _motion(self, path: str | Path) -> tuple[Motion, np.ndarray, list[str]]:
        skel, values, names, fps = parse_bvh(path, self.scale)
        skel.up = self.up
        motion = frames_to_motion(skel, values, fps, self.scale, str(path), self.root)
        return (reoriented(motion, Z_TO_Y_UP, "y") if self.up == "z" else motion), values, names

    def read_motion(self, path: str | Path) -> Motion:
        """The skeletal motion in a BVH file (Y up)."""
        return self._motion(path)[0]

    def read(self, path: str | Path) -> MotionData:
        """Raw channel values as the frame array, with the skeletal motion attached."""
        motion, values, names = self._motion(path)
        return MotionData(values.astype(np.float32), motion.fps, names, {"path": str(path)}, motion)

    def write_motion(self, motion: Motion, path: str | Path) -> None:
        """Write a skeletal motion atomically (a Y-up motion turned Z up for a Z-up file; one already Z up,
        :func:`dance_core.delivery.z_up`, as it is)."""
        text = self._text(motion)
        with atomic_path(path) as tmp:
            tmp.write_text(text, encoding="utf-8")

    def _text(self, motion: Motion) -> str:
        """The BVH text this format writes for a motion."""
        if self.up == "z" and motion.rotations is not None and motion.skeleton.up != "z":
            motion = reoriented(motion, quat_conj(Z_TO_Y_UP), "z")
        return motion_to_bvh_text(motion, 1.0 / self.scale, self.precision)

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write the skeletal motion behind ``motion`` (formats of plain feature arrays cannot). With
        ``meta["bvh_kept"] = (source, kept)`` (``compose --from --regenerate``), frames ``kept`` are written
        as the lines of the BVH file ``source`` when it has this file's hierarchy and frame count: the same
        rotations, but the Euler angles a continuous curve chose there (an equivalent triple, 360° or a
        flip apart) could otherwise differ after a regenerated span."""
        if motion.skeleton_motion is None:
            raise DataError(f"{path}: BVH needs a skeletal motion; this motion has only feature values "
                            "(set a `motion:` representation in the recipe)")
        kept = motion.meta.get("bvh_kept")
        if kept is None:
            self.write_motion(motion.skeleton_motion, path)
            return
        text = kept_lines(self._text(motion.skeleton_motion), Path(kept[0]), np.asarray(kept[1], bool))
        with atomic_path(path) as tmp:
            tmp.write_text(text, encoding="utf-8")


def build(config: Any = None, **_: Any) -> BvhFormat:
    """Build the ``bvh`` format."""
    return BvhFormat(getattr(config, "scale", 1.0), getattr(config, "precision", 6), getattr(config, "up", "y"),
                     getattr(config, "root", "auto"))

