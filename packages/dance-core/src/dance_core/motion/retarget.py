"""Retargeting: a motion on one rig played by another, whatever their names, proportions and rest poses.

Both rigs are mapped onto the canonical body (:mod:`dance_core.motion.rig_maps`). For each mapped joint
a *rest frame* is built in each rig from the rig's own rest pose: its bone direction (towards the next
mapped joint of the chain, else its End Site, first child or the parent's bone) and, across it, the
rig's forward (its up for the feet, whose bones point forward). A T-pose and an A-pose, or rigs facing
different ways, differ only in these frames, so the joint's world rotation carries over as
``W_target = W_source · F_source · F_targetᵀ``: the target's bone then points where the source's does
and twists with it. Target joints with no canonical part (extra spine or twist bones, fingers) keep their
rest pose relative to their parent; source joints with none are dropped.

The root travels with the hips: the midpoint of the hip joints follows the source's, above its floor,
scaled by the ratio of the rigs' leg lengths (so a dancer with shorter legs takes shorter steps and
the units of either rig do not matter). Last, :func:`~dance_core.motion.grounding.ground` puts the
result's feet on the floor and pins them where they are planted (the target needs named feet).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.fk import forward_kinematics
from dance_core.motion.ik import rotation_between
from dance_core.motion.motion import Motion
from dance_core.motion.rig_maps import RigMap, rig_map
from dance_core.motion.rotations import matrix_to_quat, quat_conj, quat_mul, quat_rotate
from dance_core.motion.skeleton import Skeleton

#: for each canonical joint, the canonical joints its bone points to, in order of preference
CHAIN = {
    "Pelvis": ("Spine1", "Spine2", "Spine3", "Neck"), "Spine1": ("Spine2", "Spine3", "Neck"),
    "Spine2": ("Spine3", "Neck"), "Spine3": ("Neck", "Head"), "Neck": ("Head",), "Head": (),
    **{f"{s}_{a}": b for s in "LR" for a, b in (
        ("Hip", (f"{s}_Knee",)), ("Knee", (f"{s}_Ankle",)), ("Ankle", (f"{s}_Foot",)), ("Foot", ()),
        ("Collar", (f"{s}_Shoulder",)), ("Shoulder", (f"{s}_Elbow",)), ("Elbow", (f"{s}_Wrist",)),
        ("Wrist", (f"{s}_Hand",)), ("Hand", ()))},
}
#: joints framed by the body's axes (up, forward), not by their bones: where rigs put the joints of the
#: spine, the head or the foot differs (CMU's ankle sits almost on the floor, a foot bone may point
#: forward or down), but every rest pose stands upright on flat feet, so rest is matched to rest
BODY_FRAMED = {"Pelvis", "Spine1", "Spine2", "Spine3", "Neck", "Head", "L_Ankle", "R_Ankle", "L_Foot", "R_Foot"}
_EPS = 1e-9


@dataclass
class RigFrames:
    """A rig's map, rest frames (one rotation per mapped canonical joint) and measures."""

    skeleton: Skeleton
    map: RigMap
    frames: dict[str, np.ndarray]  # canonical joint -> (4,) quaternion of its rest frame
    leg: float  # hip to knee to ankle, plus the ankle's height above the sole at rest (the rig's units)
    forward: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(float(np.linalg.norm(v)), _EPS)


def _bone(skel: Skeleton, rest: np.ndarray, rmap: RigMap, canonical: str, where: str) -> np.ndarray:
    """The rest direction of a mapped joint's bone: towards the next mapped joint of its chain (one at
    the same place, as CMU's ``LowerBack`` on ``Hips``, passes to the next), else its End Site, else its
    first descendant somewhere else; the end of a chain (head, hand, toe) may follow its parent's bone."""
    j = rmap.joints[canonical]
    tiny = 1e-6 * skel.height()
    for nxt in CHAIN[canonical]:
        k = rmap.index(nxt)
        if k is not None and np.linalg.norm(rest[k] - rest[j]) > tiny:
            return _unit(rest[k] - rest[j])
    if j in skel.end_sites and np.linalg.norm(skel.end_sites[j]) > tiny:
        return _unit(skel.end_sites[j])
    stack = list(reversed(skel.children(j)))
    while stack:  # depth-first, first child first
        k = stack.pop()
        if np.linalg.norm(rest[k] - rest[j]) > tiny:
            return _unit(rest[k] - rest[j])
        stack.extend(reversed(skel.children(k)))
    if not CHAIN[canonical] and np.linalg.norm(skel.offsets[j]) > tiny:
        return _unit(skel.offsets[j])
    raise DataError(f"{skel.where(j) if skel.source else where}: joint {skel.names[j]!r} and everything below it "
                    "are at one rest position "
                    "(zero-length bones): cannot tell where its bone points")


def rig_frames(skeleton: Skeleton, spec=None, where: str = "") -> RigFrames:
    """A rig's rest frames and leg length (``spec``: a preset name, a YAML map or None to detect)."""
    where = skeleton.where() if skeleton.source else (where or skeleton.name)
    rmap = rig_map(skeleton, spec, where)
    rest = skeleton.rest_positions()
    idx = rmap.joints
    left = rest[idx["L_Hip"]] - rest[idx["R_Hip"]] + rest[idx["L_Shoulder"]] - rest[idx["R_Shoulder"]]
    left[1] = 0.0
    if np.linalg.norm(left) < 1e-6 * skeleton.height():
        raise DataError(f"{skeleton.where(idx['L_Hip']) if skeleton.source else where}: the left and right hips "
                        "and shoulders are at the same rest position")
    up = np.array([0.0, 1.0, 0.0])
    forward = _unit(np.cross(_unit(left), up))
    frames = {}
    for canonical in idx:
        if canonical in BODY_FRAMED:  # the rest pose stands upright on flat feet in every rig
            primary, second = up, forward
        else:
            primary = _bone(skeleton, rest, rmap, canonical, where)
            second = forward - (forward @ primary) * primary
            if np.linalg.norm(second) < 1e-3:  # a limb along the forward axis at rest: twist against up
                second = up - (up @ primary) * primary
            second = _unit(second)
        frames[canonical] = matrix_to_quat(np.stack([primary, second, np.cross(primary, second)], axis=1))
    feet = [rest[idx[n]] for n in ("L_Ankle", "R_Ankle", "L_Foot", "R_Foot") if n in idx]
    feet += [rest[j] + e for j, e in skeleton.end_sites.items() if j in (idx.get("L_Ankle"), idx.get("R_Ankle"),
                                                                           idx.get("L_Foot"), idx.get("R_Foot"))]
    # the leg's length along its bones (a rest pose may splay the legs, as CMU's does), plus the ankle's
    # height above the sole
    legs = []
    for side in "LR":
        hip, knee, ankle = (rest[idx[f"{side}_{n}"]] for n in ("Hip", "Knee", "Ankle"))
        legs.append(np.linalg.norm(knee - hip) + np.linalg.norm(ankle - knee) + ankle[1] - min(p[1] for p in feet))
    leg = float(np.mean(legs))
    if leg <= 1e-6 * skeleton.height():
        raise DataError(f"{skeleton.where(idx['L_Hip']) if skeleton.source else where}: the feet are not below "
                        f"the hips in the rest pose (leg length {leg:g})")
    return RigFrames(skeleton, rmap, frames, leg, forward)


@dataclass
class RetargetReport:
    """What retargeting did: the maps used, the scale applied to travel, and the grounding's report."""

    source_map: str
    target_map: str
    scale: float
    unmapped_target: list[str]
    dropped_source: list[str]
    grounding: str = ""

    def summary(self) -> str:
        """One line for logs."""
        line = (f"retargeted ({self.source_map} -> {self.target_map} joint map), travel x{self.scale:.3g}; "
                f"{len(self.unmapped_target)} target joints at rest, {len(self.dropped_source)} source joints dropped")
        return f"{line}; {self.grounding}" if self.grounding else line


def _floor(motion: Motion, frames: RigFrames, world_p: np.ndarray, world_r: np.ndarray) -> float:
    """The source's floor: a low percentile of its lowest foot point over the take."""
    from dance_core.motion.fk import end_site_positions

    idx = frames.map.joints
    feet = [idx[n] for n in ("L_Ankle", "R_Ankle", "L_Foot", "R_Foot") if n in idx]
    low = world_p[:, feet, 1].min(axis=1)
    ends = end_site_positions(motion.skeleton, world_p, world_r)
    keys = sorted(motion.skeleton.end_sites)
    foot_ends = [i for i, k in enumerate(keys) if k in feet]
    if foot_ends:
        low = np.minimum(low, ends[:, foot_ends, 1].min(axis=1))
    return float(np.percentile(low, 2))


def _next_shared(frames: RigFrames, other: RigFrames, canonical: str) -> str | None:
    """The first joint of ``canonical``'s chain that both rigs map, away from it in both rest poses."""
    for nxt in CHAIN[canonical]:
        if nxt in frames.map.joints and nxt in other.map.joints:
            return nxt
    return None


def _follow_source_bones(world: np.ndarray, src: RigFrames, dst: RigFrames, shared: list[str],
                         src_pos: np.ndarray, src_rot: np.ndarray) -> None:
    """Add, in place, the bend that source joints with no canonical part (CMU's ``Neck1``) put between
    a mapped joint and the next: the turn from where the joint's own rotation points its rest bone to
    where the bone actually goes. Nothing changes where the source has no such joint."""
    src_rest = src.skeleton.rest_positions()
    tiny = 1e-6 * src.skeleton.height()
    mapped = {dst.map.joints[c] for c in shared}
    for c in shared:
        n = _next_shared(src, dst, c)
        if n is None:
            continue
        a, k = src.map.joints[c], src.map.joints[n]
        if src.skeleton.parents[k] == a or np.linalg.norm(src_rest[k] - src_rest[a]) < tiny:
            continue  # no joint between them
        now = quat_rotate(src_rot[:, a], src_rest[k] - src_rest[a])
        turn = rotation_between(now, src_pos[:, k] - src_pos[:, a])
        carried = _inheritors(dst.skeleton, dst.map.joints[c], mapped)
        world[:, carried] = quat_mul(turn[:, None], world[:, carried])


def _inheritors(skel: Skeleton, j: int, mapped: set[int]) -> list[int]:
    """``j`` and the unmapped joints below it that take its world rotation (down to mapped joints)."""
    out, stack = [j], list(skel.children(j))
    while stack:
        k = stack.pop()
        if k not in mapped:
            out.append(k)
            stack.extend(skel.children(k))
    return out


def retarget(motion: Motion, target: Skeleton, source_map=None, target_map=None, ground: bool = True,
             where: str = "") -> tuple[Motion, RetargetReport]:
    """``motion`` played by the ``target`` skeleton (see the module's note); maps are detected among
    the presets unless given (a preset name or a YAML file). Raises a one-line error before any work
    when either rig cannot be mapped."""
    if motion.rotations is None:
        raise DataError(f"{where or 'motion'}: retargeting needs joint rotations; this motion has positions only")
    src = rig_frames(motion.skeleton, source_map, where or motion.skeleton.name)
    dst = rig_frames(target, target_map, target.name)
    world_p, world_r = forward_kinematics(motion.skeleton, motion.root, motion.rotations)
    shared = [c for c in dst.map.joints if c in src.map.joints]
    t, n = motion.n_frames, len(target)
    world = np.zeros((t, n, 4))
    by_target = {dst.map.joints[c]: c for c in shared}
    for j in range(n):
        c = by_target.get(j)
        if c is not None:
            align = quat_mul(src.frames[c], quat_conj(dst.frames[c]))
            world[:, j] = quat_mul(world_r[:, src.map.joints[c]], align)
        elif j == 0:
            world[:, j] = [0.0, 0.0, 0.0, 1.0]
        else:
            world[:, j] = world[:, target.parents[j]]
    _follow_source_bones(world, src, dst, shared, world_p, world_r)
    local = world.copy()
    for j in range(1, n):
        local[:, j] = quat_mul(quat_conj(world[:, target.parents[j]]), world[:, j])
    local /= np.linalg.norm(local, axis=-1, keepdims=True)
    # the hips' midpoint follows the source's, above its floor, scaled by the legs
    scale = dst.leg / src.leg
    s_hips = (world_p[:, src.map.joints["L_Hip"]] + world_p[:, src.map.joints["R_Hip"]]) / 2
    s_hips[:, 1] -= _floor(motion, src, world_p, world_r)
    t_pos, _ = forward_kinematics(target, np.zeros((t, 3)), local)
    t_hips = (t_pos[:, dst.map.joints["L_Hip"]] + t_pos[:, dst.map.joints["R_Hip"]]) / 2
    root = s_hips * scale - t_hips
    out = Motion(target, motion.fps, root, local, meta=dict(motion.meta))
    report = RetargetReport(src.map.name, dst.map.name, scale,
                            [target.names[j] for j in range(n) if j not in by_target],
                            [motion.skeleton.names[j] for j in range(len(motion.skeleton))
                             if j not in {src.map.joints[c] for c in shared}])
    if ground:
        from dance_core.motion.grounding import ground as ground_motion

        out, grounding = ground_motion(out)
        report.grounding = grounding.summary()
    return out, report
