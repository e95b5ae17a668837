"""Grounding: put a skeletal dance on the floor and stop its feet from skating.

What an animator fixes by hand in generated motion, done in three steps:

1. **Contacts.** Each foot's sole height is the lower of its ankle and toe joints less their
   height above the sole (``sole`` for the toe joint; the ankle's is that plus its rest height
   above the toe). A foot is in contact while it is near the floor *the motion stands on* (the
   lowest sole over a ``floor_window``, so a dancer floating or sunk as a whole still has contacts)
   and slow (the slower of its ankle and toe; horizontal speed, or vertical when that is larger, so
   a foot taking off or landing is not in contact). Hysteresis: a contact starts below
   ``contact_height`` and ``contact_speed`` and lasts until the foot rises above
   ``release_height`` or moves faster than ``release_speed``; gaps and spans shorter than
   ``min_contact`` are flickers and are removed. Contacts are judged on the motion as grounding
   will leave it (:func:`settled_contacts`): found again on the motion as steps 2 and 3 would move it,
   adding to them until nothing is added, so that grounding the grounded motion finds them again.
2. **Height.** On frames with a contact, the root moves vertically so that the lowest sole touches
   ``y = 0`` (the contact foot's, unless the other foot is lower); between contacts the correction is
   interpolated, so a jump (no contact) keeps its flight. The correction is smoothed (Gaussian,
   ``smoothing`` seconds) and then raised smoothly wherever a foot would still be below the floor.
3. **Skating.** During each contact span the ankle is pinned horizontally to its median position
   over the span (as far as the leg reaches, the foot raised by at most ``LIFT``), and hip and knee
   are solved by two-bone IK (:mod:`dance_core.motion.ik`); around the span the ankle is shifted by
   the span's shift at its edge, fading out over ``blend`` seconds (or the gap to the next span), so
   the foot leaves and lands with its own motion. The ankle keeps its world orientation, so the toe
   follows. Where a pinned leg would be stretched (a foot that slid along with the body, held back), the
   pelvis comes down as far as keeps that leg's hip-to-ankle distance, and so its knee's bend (at most
   ``MAX_DROP``, smoothed; :func:`knee_drop`): pinned feet alone straightened the knees of generated
   dances by about 5° over their contacts. The root's horizontal track and every joint outside the legs
   stay exactly as they were around the root.

Grounding a grounded motion changes it by little: its pinned feet are their spans' medians and their
edges' shifts are zero, its contacts are found again and its soles are on the floor (about 1 cm or 1 %
of the leg at most on the CMU take 01_01 and on the bundled default's dances; 14 cm before the contacts
were settled and the fades shifted rather than pulled towards the pin).

Distances are in metres: skeletons in ``m``, ``cm`` or ``mm`` are converted; for others (BVH files
in "file" units) the unit is guessed from the leg's length (see :func:`metres_per_unit`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d, median_filter, minimum_filter1d

from dance_core.motion.fk import forward_kinematics
from dance_core.motion.ik import two_bone_ik
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import quat_conj, quat_mul, quat_rotate
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import FEET_BY_NAME

_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}


@dataclass(frozen=True)
class GroundingOptions:
    """Thresholds of the grounding step, in metres, metres per second and seconds."""

    sole: float = 0.03  # the toe joint's height above the sole (SMPL's is 2-5 cm)
    contact_height: float = 0.05  # a contact starts with the sole this close to the floor ...
    release_height: float = 0.08  # ... and ends when it rises above this
    contact_speed: float = 0.5  # horizontal foot speed under which a contact starts ...
    release_speed: float = 0.8  # ... and over which it ends
    min_contact: float = 0.1  # shorter contacts, and shorter gaps within one, are flickers
    floor_window: float = 2.0  # the floor the motion stands on: its lowest sole over this window
    max_airborne: float = 1.0  # frames farther than half this from a contact rest on the lowest sole near them
    smoothing: float = 0.1  # standard deviation of the Gaussian smoothing the height correction
    blend: float = 0.15  # the foot pinning fades in and out over this at a span's edges
    reference_leg: float = 0.8  # hip to ankle, to guess the units of skeletons without known units


@dataclass
class GroundingReport:
    """What grounding did: contact spans per foot, root correction and foot skating (metres)."""

    contacts: tuple[int, int] = (0, 0)  # contact spans of the left and right foot
    contact_fraction: float = 0.0  # frames with at least one foot in contact
    mean_correction: float = 0.0  # mean vertical root change (m; negative: lowered)
    skating_before: float = 0.0  # mean horizontal speed of feet in contact (m/s)
    skating_after: float = 0.0
    skipped: bool = False
    note: str = ""  # why grounding was skipped, or what it could not do

    def summary(self) -> str:
        """One line for logs."""
        if self.skipped:
            return f"grounding skipped: {self.note}"
        line = (f"grounded: {sum(self.contacts)} contacts ({100 * self.contact_fraction:.0f}% of frames), "
                f"root moved {100 * self.mean_correction:+.1f} cm on average, skating "
                f"{100 * self.skating_before:.1f} -> {100 * self.skating_after:.1f} cm/s")
        return f"{line}; {self.note}" if self.note else line


def find_feet(skeleton: Skeleton) -> tuple[int, int, int, int] | None:
    """Indices of (left ankle, left toe, right ankle, right toe), or None when the names are unknown:
    the foot names the metrics know, else those of a built-in rig map (Unreal, ``mixamorig:``...). A rig
    with no toe joint but an End Site under each ankle (CMU's Daz-friendly conversion) gives the ankle
    as its own toe; its End Site then serves as the toe."""
    for names in FEET_BY_NAME:
        if all(n in skeleton.names for n in names):
            return tuple(skeleton.names.index(n) for n in names)  # type: ignore[return-value]
    from dance_core.motion.rig_maps import PRESETS, apply_map

    wanted = ("L_Ankle", "L_Foot", "R_Ankle", "R_Foot")
    for name, table in PRESETS.items():
        found = apply_map(skeleton, {k: table[k] for k in wanted if k in table}, name).joints
        for side in "LR":
            ankle = found.get(f"{side}_Ankle")
            if f"{side}_Foot" not in found and ankle is not None and ankle in skeleton.end_sites:
                found[f"{side}_Foot"] = ankle
        if all(k in found for k in wanted):
            return tuple(found[k] for k in wanted)  # type: ignore[return-value]
    return None


def metres_per_unit(skeleton: Skeleton, feet: tuple[int, int, int, int], options: GroundingOptions) -> float:
    """The skeleton's unit in metres: from ``units`` when known; else metres, centimetres or
    millimetres, whichever makes the leg (hip to ankle) 0.4-1.3 m long; else ``reference_leg`` / leg."""
    if skeleton.units in _UNITS:
        return _UNITS[skeleton.units]
    knee = skeleton.parents[feet[0]]
    leg = float(np.linalg.norm(skeleton.offsets[feet[0]]) + np.linalg.norm(skeleton.offsets[knee]))
    for unit in _UNITS.values():
        if 0.4 <= leg * unit <= 1.3:
            return unit
    return options.reference_leg / max(leg, 1e-9)


def foot_points(skeleton: Skeleton, ankle: int, toe: int, with_end_sites: bool = True) -> list[int]:
    """Indices of one foot's points: its ankle and toe joints and, ``with_end_sites``, their End Sites,
    numbered as in ``Motion.positions(end_sites=True)`` (joints first, then End Sites in key order)."""
    points = [ankle] if toe == ankle else [ankle, toe]
    if with_end_sites:
        keys = sorted(skeleton.end_sites)
        points += [len(skeleton) + keys.index(j) for j in (ankle, toe) if j in skeleton.end_sites]
    return list(dict.fromkeys(points))


def sole_heights(motion: Motion, positions: np.ndarray, feet: tuple[int, int, int, int], sole: float) -> np.ndarray:
    """``(T, 2)`` heights of the left and right soles above ``y = 0``.

    Each foot point (ankle, toe, and their End Sites when ``positions`` holds them, as
    ``Motion.positions(end_sites=True)`` does) stands its rest height above the foot's lowest rest
    point; the sole is the lowest of the points less those heights, so a flat foot, a foot on its
    ball and a pointed toe all measure their lowest part. A foot whose End Sites are known has its
    sole at that lowest rest point (the rest pose stands on the floor); without them the lowest joint
    is taken to be ``sole`` (skeleton units) above it."""
    skel = motion.skeleton
    ends = positions.shape[1] > len(skel)
    rest = skel.rest_positions()
    if ends:
        from dance_core.motion.fk import end_site_positions

        keys = sorted(skel.end_sites)
        tips = end_site_positions(skel, rest[None], np.tile([0.0, 0.0, 0.0, 1.0], (1, len(skel), 1)))[0]
        rest = np.concatenate([rest, tips]) if keys else rest
    out = []
    for ankle, toe in (feet[:2], feet[2:]):
        points = foot_points(skel, ankle, toe, ends)
        lowest = rest[points, 1].min()
        known_sole = any(p >= len(skel) for p in points)
        rise = rest[points, 1] - lowest
        out.append((positions[:, points, 1] - rise).min(axis=1) - (0.0 if known_sole else sole))
    return np.stack(out, axis=1)


def foot_speeds(positions: np.ndarray, feet: tuple[int, int, int, int], fps: float,
                vertical: bool = False) -> np.ndarray:
    """``(T, 2)`` horizontal speeds of the feet, the slower of ankle and toe (units per second); with
    ``vertical``, each joint's vertical speed counts instead when it is the larger."""
    p = positions[:, list(feet)]
    if len(p) < 2:
        return np.zeros((len(p), 2))
    v = np.gradient(p, axis=0) * fps
    speed = np.linalg.norm(v[..., [0, 2]], axis=-1)
    if vertical:
        speed = np.maximum(speed, np.abs(v[..., 1]))
    return np.stack([speed[:, :2].min(1), speed[:, 2:].min(1)], axis=1)


def foot_contacts(heights: np.ndarray, speeds: np.ndarray, fps: float, options: GroundingOptions,
                  unit: float = 1.0) -> np.ndarray:
    """``(T, 2)`` contact flags from sole heights and foot speeds (skeleton units of ``unit`` metres)."""
    lowest = median_filter(heights.min(1), size=3, mode="nearest")  # a one-frame dip is no floor
    window = max(1, int(round(options.floor_window * fps)) | 1)
    above = heights - minimum_filter1d(lowest, window, mode="nearest")[:, None]
    start, hold = contact_thresholds(above, speeds, options, unit)
    contacts = np.zeros(heights.shape, bool)
    for f in range(heights.shape[1]):
        on = False
        for t in range(len(heights)):
            on = hold[t, f] if on else start[t, f]
            contacts[t, f] = on
    shortest = max(2, int(np.ceil(options.min_contact * fps - 1e-9)))
    for f in range(contacts.shape[1]):
        for start, stop in _runs(~contacts[:, f]):
            if start > 0 and stop < len(contacts) and stop - start < shortest:
                contacts[start:stop, f] = True
        for start, stop in _runs(contacts[:, f]):
            if stop - start < shortest:
                contacts[start:stop, f] = False
    return contacts


def contact_thresholds(above: np.ndarray, speeds: np.ndarray, options: GroundingOptions, unit: float = 1.0
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Where a contact may start (near the floor and slow) and where one in progress holds (below the
    release height and speed), from sole heights above the floor and foot speeds in skeleton units of
    ``unit`` metres: the hysteresis both :func:`foot_contacts` and :class:`CausalGrounding` run."""
    start = (above < options.contact_height / unit) & (speeds < options.contact_speed / unit)
    hold = (above < options.release_height / unit) & (speeds < options.release_speed / unit)
    return start, hold


def vertical_correction(heights: np.ndarray, contacts: np.ndarray, fps: float, options: GroundingOptions) -> np.ndarray:
    """``(T,)`` smooth root height change: contact feet onto the floor, no foot below it."""
    t = np.arange(len(heights))
    known = contacts.any(1)
    span = max(1, int(round(options.max_airborne * fps))) | 1
    lowest_near = minimum_filter1d(heights.min(1), span, mode="nearest")
    far = maximum_filter1d(known.astype(np.int8), span, mode="nearest") == 0  # no contact within span / 2
    anchors = known | far
    values = np.where(known, heights.min(1), lowest_near)  # a contact: the lowest sole (no foot below the floor)
    c = np.interp(t, t[anchors], -values[anchors]) if anchors.any() else np.zeros(len(heights))
    sigma = options.smoothing * fps
    if sigma > 0:
        c = gaussian_filter1d(c, sigma, mode="nearest", truncate=3.0)
    deficit = np.maximum(0.0, -heights.min(1) - c)
    if deficit.any():
        radius = int(3.0 * sigma + 0.5) if sigma > 0 else 0
        # the widened deficit averages to at least the deficit everywhere, so no foot stays below
        widened = maximum_filter1d(deficit, 2 * radius + 1, mode="nearest")
        c = c + (gaussian_filter1d(widened, sigma, mode="nearest", truncate=3.0) if sigma > 0 else widened)
    return c


def settled_contacts(motion: Motion, heights: np.ndarray, feet: tuple[int, int, int, int],
                     options: GroundingOptions, unit: float = 1.0, rounds: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """``(contacts (T, 2), correction (T,))`` of the motion as grounding leaves it: contacts are found, the
    height correction and the feet's pinning they give predicted (the ankle and toe of a pinned foot shift
    alike, as the ankle keeps its orientation), and contacts found again on that, adding to those found
    until nothing is added (at most ``rounds`` times). So a foot is judged against ``y = 0`` and at the
    speed it will have, not against a dip elsewhere in the floor window or at a speed its pin takes away,
    and grounding the grounded motion finds (within) the same contacts: it changes it by little.
    ``heights`` are the sole heights, in skeleton units of ``unit`` metres."""
    fps = motion.fps
    pos = motion.positions()
    ends = pos[:, list(feet)]
    blend = int(round(options.blend * fps))
    correction, contacts, moved, raised = np.zeros(len(heights)), None, ends, 0.0
    for _ in range(max(1, rounds)):
        found = foot_contacts(heights + correction[:, None] + raised, foot_speeds(moved, (0, 1, 2, 3), fps,
                                                                                   vertical=True), fps, options, unit)
        if contacts is not None:
            found |= contacts
            if np.array_equal(found, contacts):
                break
        contacts = found
        correction = vertical_correction(heights, contacts, fps, options)
        shifts = pin_shifts(motion.skeleton, pos, feet, contacts, blend, heights + correction[:, None])
        moved = ends + np.repeat(shifts, 2, axis=1)
        moved[..., 1] += correction[:, None]
        raised = shifts[..., 1]
    return contacts, correction


def span_pins(positions: np.ndarray, feet: tuple[int, int, int, int], contacts: np.ndarray,
              fixed: np.ndarray | None = None) -> np.ndarray:
    """``(T, 2, 2)`` where each foot is pinned (ankle x, z): in each contact span its median ankle position, or
    the pin ``fixed (T, 2, 2)`` gives on the span's frames (NaN elsewhere; a span pinned already keeps its pin);
    NaN outside contacts."""
    pins = np.full((len(positions), 2, 2), np.nan)
    for f, ankle in enumerate(feet[::2]):
        for start, stop in _runs(contacts[:, f]):
            given = fixed[start:stop, f] if fixed is not None else np.full((1, 2), np.nan)
            given = given[~np.isnan(given).any(-1)]
            pins[start:stop, f] = given[0] if len(given) else np.median(positions[start:stop, ankle][:, [0, 2]], axis=0)
    return pins


def pin_shifts(skeleton: Skeleton, positions: np.ndarray, feet: tuple[int, int, int, int], contacts: np.ndarray,
               blend: int, soles: np.ndarray | None = None, pins: np.ndarray | None = None) -> np.ndarray:
    """``(T, 2, 3)`` shift of each ankle by pinning (:func:`pin_feet`): in a contact span onto its pin
    (``pins (T, 2, 2)``, by default :func:`span_pins`: the span's median ankle position), as far as the leg
    reaches (:func:`within_reach`, raised by at most ``LIFT`` less its sole's height in ``soles (T, 2)`` when
    given); within ``blend`` frames of a span (at most the gap to the next one), the shift at the span's edge
    fading out (smoothstep; two spans' fades add up in a short gap). Zero for a leg that hangs off the root."""
    pins = span_pins(positions, feet, contacts) if pins is None else pins
    shifts = np.zeros((len(positions), 2, 3))
    lift = LIFT / metres_per_unit(skeleton, feet, GroundingOptions())
    room = np.full((len(positions), 2), lift) if soles is None else np.clip(lift - soles, 0.0, lift)
    for f, ankle in enumerate(feet[::2]):
        knee = skeleton.parents[ankle]
        hip = skeleton.parents[knee] if knee > 0 else -1
        if hip <= 0:
            continue
        reach = np.linalg.norm(skeleton.offsets[knee]) + np.linalg.norm(skeleton.offsets[ankle])
        shifts[:, f] = _pin_shifts(positions[:, ankle], positions[:, hip], contacts[:, f], blend, reach, room[:, f],
                                   pins[:, f])
    return shifts


def pin_feet(motion: Motion, feet: tuple[int, int, int, int], contacts: np.ndarray, blend_frames: int,
             soles: np.ndarray | None = None) -> Motion:
    """The motion with each contact span's ankle pinned horizontally by leg IK (legs only change; the
    ankles shifted by :func:`pin_shifts`, given the ``soles (T, 2)`` heights when known) and, with the soles
    known, the root lowered where a pinned leg would be stretched (:func:`pinning`)."""
    drop, weight, pinned = pinning(motion.skeleton, motion.positions(), feet, contacts, blend_frames, motion.fps,
                                   soles)
    if drop.any():
        root = motion.root.copy()
        root[:, 1] -= drop
        motion = replace(motion, root=root)
    return pin_legs(motion, feet, weight, pinned)


def pinning(skeleton: Skeleton, positions: np.ndarray, feet: tuple[int, int, int, int], contacts: np.ndarray,
            blend_frames: int, fps: float, soles: np.ndarray | None = None, pins: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(drop (T,), weight (T, 2), pinned (T, 2, 3))``: how far the root comes down (:func:`knee_drop`,
    zero without ``soles``), and for :func:`pin_legs` each ankle's weight and target, from the joint
    ``positions`` before the drop (the pins ``pins (T, 2, 2)`` when given, else :func:`span_pins`). With a
    drop the feet are pinned again from the lowered hips, which reach farther, the pinned feet held where
    they were."""
    ankles = list(feet[::2])
    shifts = pin_shifts(skeleton, positions, feet, contacts, blend_frames, soles, pins)
    weight = ((shifts != 0).any(-1) | contacts).astype(float)
    pinned = positions[:, ankles] + shifts
    drop = np.zeros(len(positions))
    if soles is None:
        return drop, weight, pinned
    # the pelvis comes down where a pinned leg would straighten: the knees keep their bend
    drop = knee_drop(skeleton, positions, feet, weight, pinned, soles, fps)
    if drop.any():
        kept = weight * drop[:, None]  # how far each ankle is held up against the drop
        pos = positions.copy()
        pos[..., 1] -= drop[:, None]
        pos[:, ankles, 1] += kept
        shifts = pin_shifts(skeleton, pos, feet, contacts, blend_frames, soles - drop[:, None] + kept, pins)
        pinned = pos[:, ankles] + shifts
    return drop, weight, pinned


#: the most (m) the pelvis comes down so that pinned legs keep the knees' bend (:func:`knee_drop`)
MAX_DROP = 0.06


def drop_needed(skeleton: Skeleton, positions: np.ndarray, feet: tuple[int, int, int, int], weight: np.ndarray,
                pinned: np.ndarray, soles: np.ndarray, options: GroundingOptions | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """``(need (T,), cap (T,))`` of :func:`knee_drop` frame by frame, unsmoothed: how far the root must come
    down so that each leg moved towards ``pinned`` by ``weight`` keeps its hip-to-ankle distance (at most
    ``MAX_DROP``), and how far it may (a foot not pinned, or fading in or out, stays above the floor)."""
    options = options or GroundingOptions()
    unit = metres_per_unit(skeleton, feet, options)
    need, cap = np.zeros(len(positions)), np.full(len(positions), MAX_DROP / unit)
    for f, ankle in enumerate(feet[::2]):
        knee = skeleton.parents[ankle]
        hip = skeleton.parents[knee] if knee > 0 else -1
        w = weight[:, f]
        cap = np.minimum(cap, np.where(w < 1, np.maximum(soles[:, f], 0.0) / np.maximum(1.0 - w, 1e-9), np.inf))
        if hip <= 0:
            continue
        target = positions[:, ankle] + w[:, None] * (pinned[:, f] - positions[:, ankle])
        hips = positions[:, hip]
        had = np.linalg.norm(hips - positions[:, ankle], axis=-1)
        across = np.linalg.norm((hips - target)[:, [0, 2]], axis=-1)
        above = np.sqrt(np.maximum(had * had - across * across, 0.0))  # how high the hip may stay
        # a pin farther across than the leg was long cannot keep the bend at any height: left to the IK
        need = np.maximum(need, np.where((w > 0) & (across < had), hips[:, 1] - target[:, 1] - above, 0.0))
    return np.clip(need, 0.0, MAX_DROP / unit), cap


def knee_drop(skeleton: Skeleton, positions: np.ndarray, feet: tuple[int, int, int, int], weight: np.ndarray,
              pinned: np.ndarray, soles: np.ndarray, fps: float, options: GroundingOptions | None = None
              ) -> np.ndarray:
    """``(T,)`` how far to lower the root so that each leg moved towards ``pinned (T, 2, 3)`` by ``weight
    (T, 2)`` keeps the hip-to-ankle distance, and so the knee bend, it had: a foot that slid along with the
    body, pinned, would otherwise stretch its leg (nearly straight knees at the ends of every contact, 5°
    straighter on average over a contact). At most ``MAX_DROP``; a foot not pinned, or fading in or out, is
    not taken below the floor (``soles (T, 2)``: heights above it); smoothed as the height correction is
    (Gaussian, ``options.smoothing``; the cap eroded first, so that the smoothed drop stays under it).
    Positions and the result in skeleton units. Frame by frame, unsmoothed: :func:`drop_needed`."""
    options = options or GroundingOptions()
    need, cap = drop_needed(skeleton, positions, feet, weight, pinned, soles, options)
    if not need.any():
        return need
    sigma = options.smoothing * fps
    radius = int(3.0 * sigma + 0.5) if sigma > 0 else 0
    down = minimum_filter1d(cap, 2 * radius + 1, mode="nearest")  # smoothed, still under the cap everywhere
    if sigma > 0:
        need = gaussian_filter1d(need, sigma, mode="nearest", truncate=3.0)
        down = gaussian_filter1d(down, sigma, mode="nearest", truncate=3.0)
    return np.clip(np.minimum(need, down), 0.0, None)


def pin_legs(motion: Motion, feet: tuple[int, int, int, int], weight: np.ndarray, pinned: np.ndarray) -> Motion:
    """The motion with each ankle moved horizontally towards ``pinned (T, 2, 2)`` (x, z per foot; or
    ``(T, 2, 3)``, x, y, z) by ``weight (T, 2)`` (0: as it is, 1: on the pin), hip and knee solved by
    two-bone IK (a pin the leg cannot reach: the leg points at it), the ankle keeping its world orientation;
    legs only change."""
    skel = motion.skeleton
    pos, world = forward_kinematics(skel, motion.root, motion.rotations)
    rot = motion.rotations.copy()
    for f, (ankle, toe) in enumerate((feet[:2], feet[2:])):
        knee = skel.parents[ankle]
        hip = skel.parents[knee] if knee > 0 else -1
        if hip <= 0:
            continue  # the leg hangs off the root: moving it would move the body
        frames = np.flatnonzero(weight[:, f] > 0)
        if not len(frames):
            continue
        target = pos[frames, ankle].copy()
        axes = [0, 1, 2] if pinned.shape[-1] == 3 else [0, 2]
        target[:, axes] += weight[frames, f, None] * (pinned[frames, f] - target[:, axes])
        if toe != ankle:
            forward = pos[frames, toe] - pos[frames, ankle]
        else:  # no toe joint: the ankle's End Site points along the foot
            forward = quat_rotate(world[frames, ankle], skel.end_sites.get(ankle, np.array([0.0, 0.0, 1.0])))
        forward[:, 1] = 0.0
        q_hip, q_knee = two_bone_ik(pos[frames, hip], pos[frames, knee], pos[frames, ankle], target, forward)
        hip_w = quat_mul(q_hip, world[frames, hip])
        knee_w = quat_mul(q_hip, quat_mul(q_knee, world[frames, knee]))
        for j, local in ((hip, quat_mul(quat_conj(world[frames, skel.parents[hip]]), hip_w)),
                         (knee, quat_mul(quat_conj(hip_w), knee_w)),
                         (ankle, quat_mul(quat_conj(knee_w), world[frames, ankle]))):
            same_side = (local * rot[frames, j]).sum(-1, keepdims=True) >= 0
            rot[frames, j] = np.where(same_side, local, -local)
    return replace(motion, rotations=rot)


#: how far (m) a pinned foot may rise for its straight leg to reach its pin (a pin farther away is reached only
#: as far as this lets the leg: two-bone IK would point the straight leg at it and lift the foot off the floor)
LIFT = 0.003


def within_reach(hip: np.ndarray, ankle: np.ndarray, target: np.ndarray, reach: float,
                 lift: float | np.ndarray) -> np.ndarray:
    """``target (N, 3)`` (the ``ankle`` moved horizontally) made reachable by a leg of length ``reach`` from
    ``hip``: raised as far as ``lift`` when the leg is too short for it, and moved back towards the ankle
    when even that is not enough (two-bone IK would otherwise point the straight leg at it: the foot rises
    and falls short); an ankle whose leg is already stretched farther stays where it is."""
    start, way = (ankle - hip)[:, [0, 2]], (target - ankle)[:, [0, 2]]
    depth = hip[:, 1] - target[:, 1]  # how far below the hip the target is
    flat = reach * reach - np.maximum(depth - lift, 0.0) ** 2  # the horizontal distance reachable, squared
    a = (way * way).sum(-1)
    b = (start * way).sum(-1)
    c = (start * start).sum(-1) - flat
    root = np.sqrt(np.maximum(b * b - a * c, 0.0))
    s = np.where(c > 0, 0.0, np.clip((-b + root) / np.maximum(a, 1e-18), 0.0, 1.0))
    out = ankle + s[:, None] * (target - ankle)
    across = ((start + s[:, None] * way) ** 2).sum(-1)
    short = (c <= 0) & (across + depth * depth > reach * reach)  # raised until the leg reaches it
    out[short, 1] = hip[short, 1] - np.sqrt(np.maximum(reach * reach - across[short], 0.0))
    return out


def soles(motion: Motion, options: GroundingOptions | None = None) -> np.ndarray | None:
    """``(T, 2)`` heights in metres of the left and right soles above ``y = 0``, as grounding sees them
    (End Sites of the rest pose as the sole where the skeleton has them); None without rotations or
    recognisable feet."""
    options = options or GroundingOptions()
    feet = find_feet(motion.skeleton) if motion.rotations is not None else None
    if feet is None:
        return None
    unit = metres_per_unit(motion.skeleton, feet, options)
    return sole_heights(motion, motion.positions(end_sites=True), feet, options.sole / unit) * unit


def ground(motion: Motion, options: GroundingOptions | None = None) -> tuple[Motion, GroundingReport]:
    """The motion on the floor without foot skating, and a report; unchanged (with a note) when the
    motion has no rotations or its skeleton no recognisable feet."""
    options = options or GroundingOptions()
    if motion.rotations is None:
        return motion, GroundingReport(skipped=True, note="the motion has joint positions only")
    feet = find_feet(motion.skeleton)
    if feet is None:
        note = f"skeleton {motion.skeleton.name!r} has no joints named as feet"
        return motion, GroundingReport(skipped=True, note=note)
    if motion.n_frames < 2:
        return motion, GroundingReport(skipped=True, note="a single frame")
    unit = metres_per_unit(motion.skeleton, feet, options)
    pos = motion.positions()
    heights = sole_heights(motion, motion.positions(end_sites=True), feet, options.sole / unit)
    speeds = foot_speeds(pos, feet, motion.fps)
    contacts, correction = settled_contacts(motion, heights, feet, options, unit)
    root = motion.root.copy()
    root[:, 1] += correction
    lifted = replace(motion, root=root)
    grounded = pin_feet(lifted, feet, contacts, int(round(options.blend * motion.fps)), heights + correction[:, None])
    after = foot_speeds(grounded.positions(), feet, motion.fps)
    report = GroundingReport(
        contacts=tuple(len(_runs(contacts[:, f])) for f in range(2)),  # type: ignore[arg-type]
        contact_fraction=float(contacts.any(1).mean()),
        mean_correction=float((grounded.root[:, 1] - motion.root[:, 1]).mean() * unit),  # the knee drop too
        skating_before=float(speeds[contacts].mean() * unit) if contacts.any() else 0.0,
        skating_after=float(after[contacts].mean() * unit) if contacts.any() else 0.0,
        note="" if contacts.any() else "no foot contact found; only feet below the floor were raised",
    )
    return grounded, report


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` of each run of True."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True))


def _pin_shifts(ankle: np.ndarray, hip: np.ndarray, contact: np.ndarray, blend: int, reach: float,
                lift: np.ndarray, pin: np.ndarray) -> np.ndarray:
    """One foot's ``(T, 3)`` ankle shifts (see :func:`pin_shifts`; ``ankle``, ``hip``: ``(T, 3)`` positions;
    ``pin``: ``(T, 2)`` its pins, x and z)."""
    contact = np.asarray(contact, bool)
    n = len(contact)
    shift = np.zeros((n, 3))
    runs = _runs(contact)
    target = ankle[contact]  # each frame on its own: all the spans' frames at once
    target[:, [0, 2]] = pin[contact]
    shift[contact] = within_reach(hip[contact], ankle[contact], target, reach, lift[contact]) - ankle[contact]
    edges = [0] + [e for run in runs for e in run] + [n]  # span k runs edges[2k + 1]..edges[2k + 2]
    for k, (start, stop) in enumerate(runs):
        before, after = start - edges[2 * k], edges[2 * k + 3] - stop
        for frame, edge, room, step in ((start - 1, start, before, -1), (stop, stop - 1, after, 1)):
            length = min(blend, room)
            s = 1.0 - np.arange(1, length + 1) / (length + 1)
            shift[frame + step * np.arange(length)] += (s * s * (3 - 2 * s))[:, None] * shift[edge]
    faded = (shift != 0).any(1) & ~contact
    faded_target = ankle[faded] + shift[faded]
    shift[faded] = within_reach(hip[faded], ankle[faded], faded_target, reach, lift[faded]) - ankle[faded]
    return shift
