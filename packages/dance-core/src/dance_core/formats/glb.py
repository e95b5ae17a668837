"""glTF 2.0 binary (``.glb``) motion: a skeleton as nodes and a skin, its animation, a simple body, markers.

Written: one node per joint (its rest offset as ``translation``, no rest rotation) and one per BVH-style
End Site (``extras.dance_end_site``), a skin over them (inverse bind matrices of the rest pose), one
animation (every joint's local rotation as quaternions, the root's translation; linear, one key per
frame), optionally a body of boxes bound to the bones (:mod:`~dance_core.formats.glb_body`) so it shows
in a viewer, and the dance's markers (beats, downbeats, sections, foot contacts) with its frame rate in
the animation's ``extras``. Lengths are metres and Y is up, as glTF says; a skeleton in other units is
converted (its ``units``, else guessed from the leg's length).

Read: the first skin's joints (one root; rest rotations and the static transform of the nodes above
the root are baked in, so glb files from other tools read too), the first animation sampled at its
frame rate (``extras.fps`` when we wrote it, else its key spacing), and the markers when present.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from dance_core.atomic import write_bytes
from dance_core.errors import DataError
from dance_core.formats.bvh import reoriented, written_end_sites
from dance_core.formats.glb_body import body_mesh
from dance_core.formats.glb_container import (
    ARRAY_BUFFER,
    ELEMENT_ARRAY_BUFFER,
    BinaryBuilder,
    _item,
    pack_glb,
    read_accessor,
    unpack_glb,
)
from dance_core.motion.markers import Markers, contact_spans
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import quat_conj, quat_mul, quat_rotate, unroll_quat
from dance_core.motion.skeleton import Skeleton
from dance_core.protocols import MotionData
from dance_core.version import __version__

END_MARK = "dance_end_site"
#: the longest animation read (frames), against hostile key times
MAX_FRAMES = 2_000_000


def metres_per_unit(skeleton: Skeleton) -> float:
    """The skeleton's unit in metres: from ``units`` (m, cm, mm), else guessed from the leg's length as
    grounding does, else 1."""
    from dance_core.motion.grounding import GroundingOptions, find_feet
    from dance_core.motion.grounding import metres_per_unit as guess

    feet = find_feet(skeleton)
    if skeleton.units in ("m", "cm", "mm") or feet is not None:
        return guess(skeleton, feet or (0, 0, 0, 0), GroundingOptions())
    return 1.0


def motion_to_gltf(motion: Motion, markers: Markers | None = None, body: bool = True,
                   name: str = "dance") -> tuple[dict[str, Any], bytes]:
    """The glTF document and binary buffer of a skeletal motion (see the module's description)."""
    if motion.rotations is None:
        raise DataError("glb needs joint rotations; this motion only has joint positions")
    skel = motion.skeleton
    unit = metres_per_unit(skel)
    n = len(skel)
    ends = written_end_sites(skel)
    rest = skel.rest_positions() * unit
    end_of = {j: n + k for k, j in enumerate(sorted(ends))}
    nodes: list[dict[str, Any]] = []
    for j in range(n):
        node: dict[str, Any] = {"name": skel.names[j], "translation": (skel.offsets[j] * unit).tolist()}
        children = skel.children(j) + ([end_of[j]] if j in end_of else [])
        if children:
            node["children"] = children
        nodes.append(node)
    bind = [rest[j] for j in range(n)]
    for j in sorted(ends):
        nodes.append({"name": f"{skel.names[j]}_end", "translation": (ends[j] * unit).tolist(),
                      "extras": {END_MARK: True}})
        bind.append(rest[j] + ends[j] * unit)
    buf = BinaryBuilder()
    ibm = np.tile(np.eye(4, dtype=np.float32), (len(bind), 1, 1))
    ibm[:, 3, :3] = -np.asarray(bind)  # column-major: the translation is the last column
    times = buf.add((np.arange(motion.n_frames) / motion.fps).astype(np.float32), bounds=True)
    samplers, channels = [], []
    quats = unroll_quat(motion.rotations / np.linalg.norm(motion.rotations, axis=-1, keepdims=True))
    for j in range(n):
        samplers.append({"input": times, "output": buf.add(quats[:, j].astype(np.float32)), "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": j, "path": "rotation"}})
    samplers.append({"input": times, "output": buf.add((motion.root * unit).astype(np.float32)),
                     "interpolation": "LINEAR"})
    channels.append({"sampler": len(samplers) - 1, "target": {"node": 0, "path": "translation"}})
    markers = markers or Markers()
    if not markers.contacts:
        markers = replace(markers, contacts=contact_spans(motion))
    animation = {"name": name, "samplers": samplers, "channels": channels,
                 "extras": {"fps": float(motion.fps), "frames": motion.n_frames, "markers": markers.to_dict()}}
    document: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": f"dance {__version__}"},
        "scene": 0, "scenes": [{"name": name, "nodes": [0]}], "nodes": nodes, "animations": [animation],
    }
    if body:  # without a body no skin either (one no mesh uses is an unused object): the node tree is the skeleton
        segments = [(rest[skel.parents[j]], rest[j], skel.parents[j]) for j in range(1, n)]
        segments += [(rest[j], rest[j] + ends[j] * unit, j) for j in sorted(ends)]
        mesh = body_mesh(segments)
        if len(mesh.positions):
            weights = np.zeros((len(mesh.joints), 4), np.float32)
            weights[:, 0] = 1.0
            joint_type = np.uint8 if len(bind) < 256 else np.uint16
            joints = np.zeros((len(mesh.joints), 4), joint_type)
            joints[:, 0] = mesh.joints
            index_type = np.uint16 if len(mesh.positions) < 65535 else np.uint32
            attributes = {"POSITION": buf.add(mesh.positions, ARRAY_BUFFER, bounds=True),
                          "NORMAL": buf.add(mesh.normals, ARRAY_BUFFER),
                          "JOINTS_0": buf.add(joints, ARRAY_BUFFER), "WEIGHTS_0": buf.add(weights, ARRAY_BUFFER)}
            document["meshes"] = [{"name": "body", "primitives": [{
                "attributes": attributes, "indices": buf.add(mesh.triangles.astype(index_type), ELEMENT_ARRAY_BUFFER),
                "material": 0}]}]
            document["materials"] = [{"name": "body", "pbrMetallicRoughness": {
                "baseColorFactor": [0.8, 0.55, 0.35, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8}}]
            nodes.append({"name": "body", "mesh": 0, "skin": 0})
            document["scenes"][0]["nodes"].append(len(nodes) - 1)
            document["skins"] = [{"name": f"{name}-skin", "joints": list(range(len(bind))), "skeleton": 0,
                                  "inverseBindMatrices": buf.add(ibm.reshape(-1, 16), kind="MAT4")}]
    binary = buf.buffer()
    document["buffers"] = [{"byteLength": len(binary)}]
    document["bufferViews"], document["accessors"] = buf.views, buf.accessors
    return document, binary


def _trs(node: dict[str, Any], where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A node's rest translation, rotation (unit quaternion) and scale."""
    if "matrix" in node:
        raise DataError(f"{where}: node {node.get('name', '?')!r} has a matrix transform; only TRS nodes are read")
    out = []
    for key, default in (("translation", [0.0] * 3), ("rotation", [0.0, 0.0, 0.0, 1.0]), ("scale", [1.0] * 3)):
        value = node.get(key, default)
        arr = np.asarray(value, dtype=float) if isinstance(value, list) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value) else None
        if arr is None or arr.shape != (len(default),) or not np.isfinite(arr).all():
            raise DataError(f"{where}: node {node.get('name', '?')!r}: {key} must be {len(default)} finite numbers")
        out.append(arr)
    norm = np.linalg.norm(out[1])
    if norm < 1e-6:
        raise DataError(f"{where}: node {node.get('name', '?')!r}: rotation is not a unit quaternion")
    out[1] = out[1] / norm
    return out[0], out[1], out[2]


def _sample(times: np.ndarray, values: np.ndarray, mode: str, at: np.ndarray, rotation: bool) -> np.ndarray:
    """A sampler's keys evaluated at times ``at`` (held at either end)."""
    if mode == "CUBICSPLINE":
        values = values[1::3]  # the keyed values between in- and out-tangents, interpolated linearly
    if len(times) == 1:
        return np.repeat(values[:1], len(at), axis=0)
    at = np.clip(at, times[0], times[-1])
    if mode == "STEP":
        return values[np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 1)]
    if rotation:
        return Slerp(times, Rotation.from_quat(values))(at).as_quat()
    return np.stack([np.interp(at, times, values[:, k]) for k in range(values.shape[1])], axis=1)


def _fps(animation: dict[str, Any], inputs: list[np.ndarray]) -> float:
    fps = animation.get("extras", {}).get("fps") if isinstance(animation.get("extras"), dict) else None
    if isinstance(fps, (int, float)) and not isinstance(fps, bool) and 0 < fps <= 1000:
        return float(fps)
    steps = np.concatenate([np.diff(t) for t in inputs if len(t) > 1] or [np.array([1 / 30])])
    step = float(np.median(steps[steps > 0])) if (steps > 0).any() else 1 / 30
    fps = 1.0 / step
    return float(round(fps)) if abs(fps - round(fps)) < 0.01 * fps else fps


def gltf_to_motion(document: dict[str, Any], binary: bytes, where: str) -> tuple[Motion, Markers | None]:
    """The skeletal motion (metres, Y up) and markers of a glTF document (see the module's description)."""
    nodes = document.get("nodes")
    if not isinstance(nodes, list) or not nodes:
        raise DataError(f"{where}: no nodes: a glb motion needs a skeleton")
    parent: dict[int, int] = {}
    for i, node in enumerate(nodes):
        for c in node.get("children", []) if isinstance(node, dict) else []:
            if not isinstance(c, int) or not 0 <= c < len(nodes) or c in parent or c == i:
                raise DataError(f"{where}: nodes[{i}].children: {c!r} is not a node of its own")
            parent[c] = i
    joints = _joints(document, nodes, parent, where)
    is_end = {j for j in joints if (nodes[j].get("extras") or {}) == {END_MARK: True} and parent.get(j) in joints}
    bones = [j for j in joints if j not in is_end]
    roots = [j for j in bones if parent.get(j) not in bones]
    if len(roots) != 1:
        raise DataError(f"{where}: skins[0] has {len(roots)} root joints; one skeleton with one root is read")
    order, stack = [], [roots[0]]
    while stack:  # depth-first, children in node order
        j = stack.pop()
        order.append(j)
        stack.extend(reversed([c for c in nodes[j].get("children", []) if c in bones and c not in order]))
    if len(order) != len(bones):
        raise DataError(f"{where}: skins[0].joints are not one tree under {nodes[roots[0]].get('name', '?')!r}")
    if bones[0] == roots[0] and all(bones.index(parent[j]) < k for k, j in enumerate(bones) if k):
        order = bones  # the skin's own order when parents come first (ours: the skeleton's order kept)
    index = {node: k for k, node in enumerate(order)}
    trs = {j: _trs(nodes[j], where) for j in order + sorted(is_end)}
    if any(np.abs(trs[j][2] - 1).max() > 1e-4 for j in order):
        raise DataError(f"{where}: a joint has a scale; only unscaled joints are read")
    names = [str(nodes[j].get("name", f"joint{j}"))[:200] for j in order]
    if len(set(names)) != len(names):
        names = [f"{n}_{k}" for k, n in enumerate(names)]
    skel = Skeleton(names, [index[parent[j]] if k else -1 for k, j in enumerate(order)],
                    np.array([trs[j][0] for j in order]), end_sites={index[parent[e]]: trs[e][0] for e in is_end},
                    units="m", name=Path(where).stem, source=where)
    animation = (document.get("animations") or [None])[0]
    rot = np.tile(np.array([trs[j][1] for j in order]), (1, 1, 1))
    root = skel.offsets[:1].copy()
    fps = 30.0
    markers = None
    if isinstance(animation, dict):
        rot, root, fps = _animated(document, binary, animation, index, trs, order, where)
        extras = animation.get("extras")
        if isinstance(extras, dict) and "markers" in extras:
            markers = Markers.from_dict(extras["markers"], f"{where}: animations[0].extras")
    motion = _baked(Motion(skel, fps, root, rot), np.array([trs[j][1] for j in order]))
    return _placed(motion, nodes, parent, roots[0], where), markers


def _joints(document: dict[str, Any], nodes: list, parent: dict[int, int], where: str) -> list[int]:
    """The skeleton's nodes: the first skin's joints; without a skin (``glb`` with ``body: false``), the
    tree under the default scene's first node, the nodes carrying a mesh left out."""
    skins = document.get("skins")
    if isinstance(skins, list) and skins:
        joints = _item(document, "skins", 0, where).get("joints")
        if not isinstance(joints, list) or not joints:
            raise DataError(f"{where}: skins[0].joints is empty")
    else:
        scene = _item(document, "scenes", document.get("scene", 0), where)
        roots = scene.get("nodes")
        if not isinstance(roots, list) or not roots:
            raise DataError(f"{where}: no skin and no scene nodes: a glb motion needs a skeleton")
        joints, stack = [], [roots[0]]
        while stack and len(joints) <= len(nodes):
            j = stack.pop()
            node = _item(document, "nodes", j, where)
            if "mesh" not in node:
                joints.append(j)
                stack.extend(reversed(node.get("children", [])))
        joints.sort()  # node order: ours lists the joints in the skeleton's order
    for j in joints:
        _item(document, "nodes", j, where)
    return joints


def _animated(document, binary, animation, index, trs, order, where):
    """Local rotations ``(T, J, 4)``, root positions ``(T, 3)`` and fps of an animation's joint channels."""
    samplers, channels = animation.get("samplers", []), animation.get("channels", [])
    if not isinstance(samplers, list) or not isinstance(channels, list):
        raise DataError(f"{where}: animations[0] has no samplers or channels")
    keyed = []
    for k, ch in enumerate(channels):
        target = ch.get("target", {}) if isinstance(ch, dict) else {}
        node, path = target.get("node"), target.get("path")
        if node not in index or path not in ("rotation", "translation"):
            continue
        s = ch.get("sampler")
        if not isinstance(s, int) or not 0 <= s < len(samplers) or not isinstance(samplers[s], dict):
            raise DataError(f"{where}: animations[0].channels[{k}].sampler does not exist")
        times = read_accessor(document, binary, samplers[s].get("input"), where)[:, 0]
        values = read_accessor(document, binary, samplers[s].get("output"), where)
        mode = samplers[s].get("interpolation", "LINEAR")
        width = 4 if path == "rotation" else 3
        if mode not in ("LINEAR", "STEP", "CUBICSPLINE") or values.shape[1] != width \
                or len(values) != len(times) * (3 if mode == "CUBICSPLINE" else 1) or not len(times) \
                or (np.diff(times) <= 0).any():
            raise DataError(f"{where}: animations[0].samplers[{s}]: keys and values do not match "
                            "(increasing times, one value per key)")
        keyed.append((index[node], path, times, values, mode))
    fps = _fps(animation, [t for _, _, t, _, _ in keyed])
    start = min((t[0] for _, _, t, _, _ in keyed), default=0.0)
    end = max((t[-1] for _, _, t, _, _ in keyed), default=0.0)
    n = int(round((end - start) * fps)) + 1
    if n > MAX_FRAMES:
        raise DataError(f"{where}: animations[0] lasts {end - start:.0f} s at {fps:g} fps: too long to read")
    at = start + np.arange(n) / fps
    rot = np.tile(np.array([trs[j][1] for j in order]), (n, 1, 1))
    root = np.tile(trs[order[0]][0], (n, 1))
    for j, path, times, values, mode in keyed:
        if path == "rotation":
            if (np.linalg.norm(values, axis=1) < 1e-6).any():
                raise DataError(f"{where}: animations[0]: a rotation key of {order[j]} is not a unit quaternion")
            rot[:, j] = _sample(times, values / np.linalg.norm(values, axis=1, keepdims=True), mode, at, True)
        elif j == 0:
            root = _sample(times, values, mode, at, False)
        elif np.ptp(values, axis=0).max() > 1e-6:
            raise DataError(f"{where}: animations[0] moves joint {order[j]} (not the root); only the root may move")
    return rot, root, fps


def _baked(motion: Motion, rest: np.ndarray) -> Motion:
    """The motion on a skeleton whose rest pose has no joint rotations (``rest``: each joint's rest
    rotation): offsets turned into the parents' rest frames, rotations taken relative to the rest."""
    if np.abs(np.abs(rest[:, 3]) - 1).max() < 1e-9:
        return motion
    skel = motion.skeleton
    world = rest.copy()
    for j in range(1, len(skel)):
        world[j] = quat_mul(world[skel.parents[j]], rest[j])
    parent_world = np.array([world[p] if p >= 0 else [0.0, 0.0, 0.0, 1.0] for p in skel.parents])
    offsets = skel.offsets.copy()
    offsets[1:] = quat_rotate(parent_world[1:], skel.offsets[1:])
    ends = {j: quat_rotate(world[j], e) for j, e in skel.end_sites.items()}
    turned = Skeleton(list(skel.names), list(skel.parents), offsets, end_sites=ends, units=skel.units,
                      name=skel.name, source=skel.source)
    rot = quat_mul(quat_mul(parent_world[None], motion.rotations), quat_conj(world)[None])
    return Motion(turned, motion.fps, motion.root, rot, meta=motion.meta)


def _placed(motion: Motion, nodes: list, parent: dict[int, int], root: int, where: str) -> Motion:
    """The motion under the static transform of the nodes above its root joint (uniform scale only)."""
    t, q, s = np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), 1.0
    node, seen = parent.get(root), set()
    while node is not None and node not in seen:
        seen.add(node)
        nt, nq, ns = _trs(nodes[node], where)
        if np.ptp(ns) > 1e-6 * abs(ns[0]) or ns[0] <= 0:
            raise DataError(f"{where}: node {nodes[node].get('name', '?')!r} above the skeleton has a "
                            "non-uniform or negative scale")
        t, q, s = nt + ns[0] * quat_rotate(nq, t), quat_mul(nq, q), ns[0] * s
        node = parent.get(node)
    if abs(s - 1) < 1e-9 and np.abs(t).max() < 1e-12 and abs(abs(q[3]) - 1) < 1e-12:
        return motion
    motion = Motion(motion.skeleton.scaled(s), motion.fps, motion.root * s, motion.rotations, meta=motion.meta)
    if abs(abs(q[3]) - 1) > 1e-12:
        motion = reoriented(motion, q)
    return Motion(motion.skeleton, motion.fps, motion.root + t, motion.rotations, meta=motion.meta)


def positions_data(motion: Motion, meta: dict[str, Any] | None = None) -> MotionData:
    """A skeletal motion as ``MotionData``: its joint positions as the frame array (channels ``JOINT.x``...),
    the motion attached."""
    pos = motion.positions()
    channels = [f"{name}.{axis}" for name in motion.skeleton.names for axis in "xyz"]
    return MotionData(pos.reshape(len(pos), -1).astype(np.float32), motion.fps, channels, dict(meta or {}), motion)


class GlbFormat:
    """The ``glb`` motion format: skeletal motion as glTF 2.0 binary (``body``: add the box body)."""

    def __init__(self, body: bool = True):
        self.body = body

    def read_motion(self, path: str | Path) -> tuple[Motion, Markers | None]:
        """The skeletal motion in a glb file and its markers (None when it has none)."""
        path = Path(path)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            raise DataError(f"{path}: motion file not found") from None
        except IsADirectoryError:
            raise DataError(f"{path}: is a folder, not a glb file") from None
        document, binary = unpack_glb(data, str(path))
        return gltf_to_motion(document, binary, str(path))

    def read(self, path: str | Path) -> MotionData:
        """Joint positions as the frame array, the skeletal motion attached, markers in ``meta``."""
        motion, markers = self.read_motion(path)
        meta: dict[str, Any] = {"path": str(path)}
        if markers is not None:
            meta["markers"] = markers
        return positions_data(motion, meta)

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write the skeletal motion behind ``motion`` atomically, with ``meta["markers"]`` when present."""
        if motion.skeleton_motion is None:
            raise DataError(f"{path}: glb needs a skeletal motion; this motion has only feature values "
                            "(set a `motion:` representation in the recipe)")
        markers = motion.meta.get("markers") if isinstance(motion.meta, dict) else None
        name = str(motion.meta.get("title") or Path(path).stem) if isinstance(motion.meta, dict) else Path(path).stem
        document, binary = motion_to_gltf(motion.skeleton_motion, markers, self.body, name)
        write_bytes(path, pack_glb(document, binary))


def build(config: Any = None, **_: Any) -> GlbFormat:
    """Build the ``glb`` format."""
    return GlbFormat(getattr(config, "body", True))
