"""BVH read/write: any channel order, End Sites, depth-first frame layout, unit scale, continuous Euler."""

from __future__ import annotations

import io
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


def _fps(frame_time: float) -> float:
    fps = 1.0 / frame_time
    return float(round(fps)) if abs(fps - round(fps)) < 1e-3 * fps else fps


class _Parser:
    """A small recursive-descent parser over whitespace tokens of the HIERARCHY section."""

    def __init__(self, path: Path, tokens: list[str]):
        self.path, self.tokens, self.i = path, tokens, 0
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[tuple[str, ...]] = []
        self.end_sites: dict[int, np.ndarray] = {}

    def fail(self, what: str):
        raise DataError(f"{self.path}: BVH HIERARCHY: {what} (token {self.i})")

    def take(self, expected: str | None = None) -> str:
        if self.i >= len(self.tokens):
            self.fail(f"unexpected end, expected {expected or 'more'}")
        tok = self.tokens[self.i]
        self.i += 1
        if expected is not None and tok.upper() != expected.upper():
            self.fail(f"expected {expected!r}, found {tok!r}")
        return tok

    def numbers(self, n: int) -> list[float]:
        try:
            return [float(self.take()) for _ in range(n)]
        except ValueError:
            self.fail("a number was expected")

    def joint(self, parent: int) -> None:
        name = self.take()
        if name.upper() == "SITE":  # "End Site" reached through a misplaced keyword
            self.fail("End Site outside a joint")
        index = len(self.names)
        self.names.append(name)
        self.parents.append(parent)
        self.take("{")
        self.take("OFFSET")
        self.offsets.append(self.numbers(3))
        chans: tuple[str, ...] = ()
        if self.tokens[self.i].upper() == "CHANNELS":
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


def parse_bvh(path: str | Path, scale: float = 1.0) -> tuple[Skeleton, np.ndarray, list[str], float]:
    """Skeleton, raw frame array ``(T, C)``, channel names and fps of a BVH file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        raise DataError(f"{path}: motion file not found") from None
    head, sep, motion = text.partition("MOTION")
    if not sep:
        raise DataError(f"{path}: not a BVH file (no MOTION section)")
    tokens = head.split()
    if not tokens or tokens[0].upper() != "HIERARCHY":
        raise DataError(f"{path}: not a BVH file (no HIERARCHY)")
    p = _Parser(path, tokens)
    p.i = 1
    p.take("ROOT")
    p.joint(-1)
    lines = motion.strip().splitlines()
    try:
        n_frames = int(lines[0].split(":")[1])
        frame_time = float(lines[1].split(":")[1])
        rows = [ln.split() for ln in lines[2 : 2 + n_frames] if ln.strip()]
        values = np.array(rows, dtype=np.float64).reshape(len(rows), -1)
    except (IndexError, ValueError):
        raise DataError(f"{path}: BVH MOTION: bad Frames/Frame Time lines or non-numeric frame data") from None
    n_ch = sum(len(c) for c in p.channels)
    if len(rows) != n_frames or values.shape[1] != n_ch or frame_time <= 0:
        raise DataError(f"{path}: BVH MOTION: {n_frames} frames of {n_ch} channels declared, "
                        f"found {len(rows)} x {values.shape[1] if rows else 0} (frame time {frame_time})")
    skel = Skeleton(p.names, p.parents, np.array(p.offsets) * scale, p.channels,
                    {k: v * scale for k, v in p.end_sites.items()}, name=path.stem,
                    units="file" if scale == 1.0 else f"file x {scale:g}")
    names = [f"{p.names[j]}.{c}" for j in range(len(p.names)) for c in p.channels[j]]
    return skel, values, names, _fps(frame_time)


def frames_to_motion(skel: Skeleton, values: np.ndarray, fps: float, scale: float = 1.0, where: str = "") -> Motion:
    """Raw BVH frame rows to a :class:`Motion` (position channels scaled by ``scale``)."""
    t = len(values)
    rotations = np.zeros((t, len(skel), 4))
    rotations[..., 3] = 1.0
    root = np.repeat(skel.offsets[:1], t, axis=0)
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
                root[:, axis] = skel.offsets[0, axis] + block[:, k] * scale
        elif pos:
            for k, axis in pos:
                if np.ptp(block[:, k]) > 1e-6:
                    raise DataError(f"{where}: joint {skel.names[j]!r} has animated translation; "
                                    "only the root may move")
                offsets[j, axis] = block[0, k] * scale
    if not np.array_equal(offsets, skel.offsets):
        skel.offsets = offsets
    return Motion(skel, fps, root, rotations)


def dfs_order(skel: Skeleton) -> list[int]:
    """Joints in depth-first order (children in index order): BVH's hierarchy and frame layout."""
    order: list[int] = []
    stack = [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(skel.children(j)))
    return order


def _writer_channels(skel: Skeleton, j: int) -> tuple[str, ...]:
    chans = tuple(c for c in skel.channels[j] if c in ROTATIONS) or ("Zrotation", "Xrotation", "Yrotation")
    return (POSITIONS + chans) if j == 0 else chans


def motion_to_bvh_text(motion: Motion, scale: float = 1.0, precision: int = 6) -> str:
    """BVH text of a motion (``scale`` multiplies lengths on the way out)."""
    if motion.rotations is None:
        raise DataError("BVH needs joint rotations; this motion only has joint positions")
    skel = motion.skeleton
    order = dfs_order(skel)
    out = ["HIERARCHY"]
    depth_of = {0: 0}

    def emit(j: int) -> None:
        d = depth_of[j]
        pad = "\t" * d
        kw = "ROOT" if j == 0 else "JOINT"
        out.append(f"{pad}{kw} {skel.names[j]}")
        out.append(f"{pad}{{")
        off = skel.offsets[j] * scale
        out.append(f"{pad}\tOFFSET {off[0]:.{precision}f} {off[1]:.{precision}f} {off[2]:.{precision}f}")
        chans = _writer_channels(skel, j)
        out.append(f"{pad}\tCHANNELS {len(chans)} {' '.join(chans)}")
        for c in skel.children(j):
            depth_of[c] = d + 1
            emit(c)
        if j in skel.end_sites:
            e = skel.end_sites[j] * scale
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
    cols = [(motion.root - skel.offsets[0]) * scale] + [euler[j] for j in order]
    frames = np.concatenate(cols, axis=1)
    out += ["MOTION", f"Frames: {len(frames)}", f"Frame Time: {1.0 / motion.fps:.8f}"]
    buf = io.StringIO()
    np.savetxt(buf, frames, fmt=f"%.{precision}f", delimiter=" ")
    return "\n".join(out) + "\n" + buf.getvalue()


#: the rotation taking a Z-up world to our Y-up one (-90 degrees about X)
Z_TO_Y_UP = np.array([-np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)])


def reoriented(motion: Motion, q: np.ndarray) -> Motion:
    """The motion expressed in a world turned by quaternion ``q``: a change of basis, so rest offsets
    and End Sites turn with it and every local rotation becomes ``q r q^-1`` (the rest pose stands
    up in the new world, and world positions are ``q`` applied to the old ones)."""
    from dataclasses import replace

    skel = motion.skeleton
    turned = Skeleton(list(skel.names), list(skel.parents), quat_rotate(q, skel.offsets), list(skel.channels),
                      {k: quat_rotate(q, v) for k, v in skel.end_sites.items()}, skel.units,
                      "y" if skel.up == "z" else "z", skel.name)
    rot = quat_mul(quat_mul(q, motion.rotations), quat_conj(q))
    return replace(motion, skeleton=turned, root=quat_rotate(q, motion.root), rotations=rot)


class BvhFormat:
    """The ``bvh`` motion format; ``scale`` converts file units on read (and back on write), and
    ``up="z"`` turns Z-up files into our Y-up convention (and back on write)."""

    def __init__(self, scale: float = 1.0, precision: int = 6, up: str = "y"):
        self.scale = scale
        self.precision = precision
        self.up = up

    def _motion(self, path: str | Path) -> tuple[Motion, np.ndarray, list[str]]:
        skel, values, names, fps = parse_bvh(path, self.scale)
        skel.up = self.up
        motion = frames_to_motion(skel, values, fps, self.scale, str(path))
        return (reoriented(motion, Z_TO_Y_UP) if self.up == "z" else motion), values, names

    def read_motion(self, path: str | Path) -> Motion:
        """The skeletal motion in a BVH file (Y up)."""
        return self._motion(path)[0]

    def read(self, path: str | Path) -> MotionData:
        """Raw channel values as the frame array, with the skeletal motion attached."""
        motion, values, names = self._motion(path)
        return MotionData(values.astype(np.float32), motion.fps, names, {"path": str(path)}, motion)

    def write_motion(self, motion: Motion, path: str | Path) -> None:
        """Write a skeletal motion atomically."""
        if self.up == "z" and motion.rotations is not None:
            motion = reoriented(motion, quat_conj(Z_TO_Y_UP))
        text = motion_to_bvh_text(motion, 1.0 / self.scale, self.precision)
        with atomic_path(path) as tmp:
            tmp.write_text(text, encoding="utf-8")

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write the skeletal motion behind ``motion`` (formats of plain feature arrays cannot)."""
        if motion.skeleton_motion is None:
            raise DataError(f"{path}: BVH needs a skeletal motion; this motion has only feature values "
                            "(set a `motion:` representation in the recipe)")
        self.write_motion(motion.skeleton_motion, path)


def build(config: Any = None, **_: Any) -> BvhFormat:
    """Build the ``bvh`` format."""
    return BvhFormat(getattr(config, "scale", 1.0), getattr(config, "precision", 6), getattr(config, "up", "y"))

