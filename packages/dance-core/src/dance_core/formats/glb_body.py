"""A simple skinned body for a skeleton: one box along each bone, rigidly bound to the bone's joint.

Enough to see a dance when a glb is dropped into a viewer or an engine; a real character comes in
through retargeting (``dance convert --rig``). Each box has its own vertices per face (flat normals)
and counter-clockwise triangles seen from outside, as glTF expects.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a box's width as a fraction of its bone's length, and its bounds in metres
WIDTH, LEAST, MOST = 0.3, 0.03, 0.09


@dataclass
class BodyMesh:
    """Bind-pose vertices (metres), flat normals, the joint (skin index) each vertex follows, triangles."""

    positions: np.ndarray  # (V, 3) float32
    normals: np.ndarray  # (V, 3) float32
    joints: np.ndarray  # (V,) int
    triangles: np.ndarray  # (F * 3,) int


def _unit_box() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Corners, outward normals and triangles of the cube [-1, 1]^3, four corners per face."""
    corners, normals, tris = [], [], []
    for axis in range(3):
        b, c = (axis + 1) % 3, (axis + 2) % 3
        for sign in (-1.0, 1.0):
            square = [(-1, -1), (1, -1), (1, 1), (-1, 1)]  # counter-clockwise seen from +axis
            if sign < 0:
                square = square[::-1]
            base = len(corners)
            for u, v in square:
                p = np.zeros(3)
                p[axis], p[b], p[c] = sign, u, v
                corners.append(p)
                normals.append(np.eye(3)[axis] * sign)
            tris += [base, base + 1, base + 2, base, base + 2, base + 3]
    return np.array(corners), np.array(normals), np.array(tris)


def body_mesh(segments: list[tuple[np.ndarray, np.ndarray, int]]) -> BodyMesh:
    """Boxes along ``(start, end, joint)`` segments (bind-pose metres); segments shorter than 1 mm are skipped."""
    corners, normals, tris = _unit_box()
    pos, nor, idx, out_tris = [], [], [], []
    for start, end, joint in segments:
        bone = np.asarray(end, float) - np.asarray(start, float)
        length = float(np.linalg.norm(bone))
        if length < 1e-3:
            continue
        along = bone / length
        helper = np.eye(3)[int(np.argmin(np.abs(along)))]
        side = np.cross(helper, along)
        side /= np.linalg.norm(side)
        basis = np.stack([side, along, np.cross(side, along)], axis=1)  # right-handed: windings kept
        half = 0.5 * float(np.clip(WIDTH * length, LEAST, MOST))
        local = corners * np.array([half, 0.5 * length, half]) + np.array([0.0, 0.5 * length, 0.0])
        out_tris.append(tris + sum(len(p) for p in pos))
        pos.append(local @ basis.T + start)
        nor.append(normals @ basis.T)
        idx.append(np.full(len(corners), joint))
    if not pos:
        return BodyMesh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32), np.zeros(0, int), np.zeros(0, int))
    return BodyMesh(np.concatenate(pos).astype(np.float32), np.concatenate(nor).astype(np.float32),
                    np.concatenate(idx), np.concatenate(out_tris))
