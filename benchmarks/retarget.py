"""Retargeting quality on real dance mocap: every CMU dance take onto our ``dance24``, onto a Mixamo-named
centimetre rig in an A-pose, and back onto the take's own skeleton, beside controls that must fail.

    .venv/bin/python benchmarks/retarget.py [--mocap FOLDER] [--only GLOB] [--json FILE] [--per-take]

``--mocap`` defaults to ``../shared/mocap/cmu-dance`` relative to the repository root (read in place, never
copied). All 29 takes by default (``--only 'salsa_60_0*.bvh'`` picks some); about 25 s on the project's
2-core VM, one process, numpy only. Prints markdown tables (the README's "Retargeting" section); ``--json``
also writes every per-take figure (``-`` for stdout).

Per take (the first ``SKIP`` frames, the conversion's T-pose and start-up transient, are dropped):

- **trajectory error / leg**: for every canonical joint both rigs map, its trajectory relative to the
  hip midpoint divided by its rig's leg length (:func:`dance_core.motion.retarget.rig_frames`), source
  against result; mean distance over frames, after removing each trajectory's mean over the take (constant
  proportion offsets do not count), and without that ("raw"); mean over joints and the worst joint.
- **travel error**: the hip midpoint's ground-plane path length per leg length, result against source,
  at the end of the take, as a fraction of the source's.
- **bone direction error** (degrees) of the limb bones (collar->shoulder, shoulder->elbow, elbow->wrist,
  hip->knee, knee->ankle): mean and 99th percentile over bones and frames.
- **foot skating**: mean horizontal foot speed (slower of ankle and toe, as grounding measures it) while
  in contact, contacts found by :func:`dance_core.motion.grounding.foot_contacts` on the motion itself;
  in leg lengths/s and in cm/s for a 0.90 m leg (dance24's; the source takes are read as if their leg were
  that long). The share of frames in contact is shown, so a motion that never touches the floor cannot
  score well unnoticed; and the share of frames with a foot point (ankle, toe, their End Sites) more than
  1 cm below the floor (y = 0).
- **round trip** take -> dance24 -> take (without grounding both ways, and with): mapped joints' position
  error per leg length (one constant vertical shift removed: retargeting stands the result on the floor
  its source's feet reach) and world rotation error (degrees); unmapped joints (fingers, buttocks) are
  left out.
- time per retargeting call.

Controls (a measure is only good if the obvious cheat fails it): **naive** retargeting (local rotations
copied by joint map, no rest-pose alignment, root copied without scaling; onto the A-pose Mixamo rig and
onto dance24), the take's **frames shuffled** in time before retargeting, and the result **shifted by
0.5 s** against the source; a control fails a measure when it scores at least ``FAIL_RATIO`` times the
engine on every take. A diagnostic row retargets onto dance24 with its shoulders moved to the take's
shoulder width (how much of the trajectory error is that one proportion).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from dance_core import Motion, Skeleton
from dance_core.api import read_motion, retarget
from dance_core.motion import (
    GroundingOptions,
    RigFrames,
    arms_lowered,
    dance24,
    find_feet,
    foot_contacts,
    foot_speeds,
    renamed,
    rig_frames,
    sole_heights,
)

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / ".." / "shared" / "mocap" / "cmu-dance"
SKIP = 10  # leading frames dropped: the conversion's T-pose and a start-up transient
SHIFT_S = 0.5  # the time-shift control
LEG_M = 0.90  # leg length in metres that speeds in cm/s assume (dance24's; sources read as if theirs were)
BELOW_M = 0.01  # a foot more than this below y = 0 is under the floor
LIMBS = [(f"{s}_{a}", f"{s}_{b}") for s in "LR" for a, b in
         (("Collar", "Shoulder"), ("Shoulder", "Elbow"), ("Elbow", "Wrist"), ("Hip", "Knee"), ("Knee", "Ankle"))]


def mixamo_rig() -> Skeleton:
    """Our body as a Mixamo character would carry it: ``mixamorig:`` names, centimetres, A-pose."""
    return renamed(arms_lowered(dance24()), "mixamo", "mixamorig:").scaled(100.0, "cm")


def narrow_shoulders(skel: Skeleton, source: Skeleton) -> Skeleton:
    """Diagnostic: ``skel`` (SMPL-24 names) with its shoulder joints as far apart, per leg length, as the
    ``source`` rig's (the collar bones shortened or lengthened sideways; the arms hang off them as before)."""
    src, dst = rig_frames(source), rig_frames(skel)
    rest_s = source.rest_positions()
    width = abs(rest_s[src.map.joints["L_Shoulder"], 0] - rest_s[src.map.joints["R_Shoulder"], 0]) / src.leg
    rest, offsets = skel.rest_positions(), skel.offsets.copy()
    for side, sign in (("L", 1.0), ("R", -1.0)):
        j = skel.names.index(f"{side}_Shoulder")
        offsets[j, 0] = sign * width / 2 * dst.leg - rest[skel.parents[j], 0]
    return replace(skel, offsets=offsets, name=f"{skel.name}-narrow")


def naive_retarget(motion: Motion, target: Skeleton) -> Motion:
    """The cheat: each target joint takes the local rotation of the source joint its map names, and the
    root moves from the target's rest position as the source's moves from its own, in the source's units
    (no rest-pose alignment, no scaling, no grounding)."""
    src, dst = rig_frames(motion.skeleton).map, rig_frames(target).map
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (motion.n_frames, len(target), 1))
    for canonical, j in dst.joints.items():
        if canonical in src.joints:
            rot[:, j] = motion.rotations[:, src.joints[canonical]]
    return Motion(target, motion.fps, target.offsets[0] + motion.root - motion.skeleton.offsets[0], rot)


@dataclass
class Played:
    """A motion with its rig's map and leg, world positions (End Sites appended) and rotations."""

    motion: Motion
    rig: RigFrames
    pos: np.ndarray
    rot: np.ndarray

    @classmethod
    def of(cls, motion: Motion, rig: RigFrames | None = None) -> Played:
        """FK of ``motion`` (its rig's frames computed unless given)."""
        from dance_core.motion import end_site_positions, forward_kinematics

        rig = rig or rig_frames(motion.skeleton)
        pos, rot = forward_kinematics(motion.skeleton, motion.root, motion.rotations)
        pos = np.concatenate([pos, end_site_positions(motion.skeleton, pos, rot)], axis=1)
        return cls(motion, rig, pos, rot)

    def joint(self, canonical: str) -> np.ndarray:
        """``(T, 3)`` world trajectory of a canonical joint."""
        return self.pos[:, self.rig.map.joints[canonical]]

    def hips(self) -> np.ndarray:
        """``(T, 3)`` midpoint of the hip joints."""
        return (self.joint("L_Hip") + self.joint("R_Hip")) / 2

    def end_site(self, j: int) -> int | None:
        """Index in ``pos`` of joint ``j``'s End Site, or None."""
        keys = sorted(self.motion.skeleton.end_sites)
        return len(self.motion.skeleton) + keys.index(j) if j in keys else None

    def feet(self) -> tuple[tuple[int, int, int, int], list[list[int]]]:
        """(left ankle, left toe, right ankle, right toe) indices in ``pos`` (a toe joint when the map
        has one, else the ankle's End Site) and, per foot, every foot point (joints and End Sites)."""
        quad, points = [], []
        for side in "LR":
            ankle = self.rig.map.joints[f"{side}_Ankle"]
            toe = self.rig.map.index(f"{side}_Foot")
            tip = self.end_site(ankle if toe is None else toe)
            toe = tip if toe is None else toe
            if toe is None:
                raise SystemExit(f"{self.motion.skeleton.name}: no toe joint or End Site on the {side} foot")
            quad += [ankle, toe]
            points.append(sorted({p for p in (ankle, toe, tip, self.end_site(ankle)) if p is not None}))
        return tuple(quad), points  # type: ignore[return-value]

    def unit(self) -> float:
        """Metres per rig unit, for the contact thresholds: ``LEG_M`` / leg length."""
        return LEG_M / self.rig.leg


def rest_with_ends(skel: Skeleton) -> np.ndarray:
    """Rest positions of the joints with the End Sites appended (``Played.pos``'s columns)."""
    rest = skel.rest_positions()
    ends = [rest[j] + skel.end_sites[j] for j in sorted(skel.end_sites)]
    return np.concatenate([rest, np.reshape(ends, (-1, 3))])


def foot_measures(p: Played) -> dict:
    """Skating (leg/s and cm/s at a 0.90 m leg) of the feet while in contact, contact share, share of frames
    with a foot point more than 1 cm below y = 0."""
    opts = GroundingOptions()
    feet, points = p.feet()
    unit, fps = p.unit(), p.motion.fps
    # the soles as grounding measures them (its own function: foot points with End Sites, each less its
    # rest height above the foot's lowest rest point)
    joints = find_feet(p.motion.skeleton)
    heights = sole_heights(p.motion, p.pos, joints, opts.sole / unit)
    contacts = foot_contacts(heights, foot_speeds(p.pos, feet, fps, vertical=True), fps, opts, unit)
    speeds = foot_speeds(p.pos, feet, fps) / p.rig.leg  # leg lengths per second
    skate = float(speeds[contacts].mean()) if contacts.any() else float("nan")
    lowest = np.min([p.pos[:, pts, 1].min(axis=1) for pts in points], axis=0)
    return {"skating_leg_s": skate, "skating_cm_s": 100 * LEG_M * skate,
            "contact": float(contacts.any(axis=1).mean()),
            "below_floor": float((lowest < -BELOW_M / unit).mean()),
            "below_p99_cm": float(-100 * unit * np.percentile(lowest, 1)),
            "lowest_median_cm": float(100 * unit * np.median(lowest))}


def trajectory_error(src: Played, out: Played) -> dict:
    """Joint trajectories relative to the hip midpoint, per leg length, source against result frame by
    frame; mean-removed and raw, mean over joints and the worst joint."""
    shared = [c for c in out.rig.map.joints if c in src.rig.map.joints]
    a = np.stack([src.joint(c) - src.hips() for c in shared], 1) / src.rig.leg
    b = np.stack([out.joint(c) - out.hips() for c in shared], 1) / out.rig.leg
    raw = np.linalg.norm(a - b, axis=-1).mean(0)
    centred = np.linalg.norm((a - a.mean(0)) - (b - b.mean(0)), axis=-1).mean(0)
    worst = int(np.argmax(centred))
    return {"traj": float(centred.mean()), "traj_worst": float(centred[worst]), "traj_worst_joint": shared[worst],
            "traj_joints": dict(zip(shared, centred.round(5).tolist(), strict=True)),
            "traj_raw": float(raw.mean()), "traj_raw_worst": float(raw.max()),
            "traj_raw_worst_joint": shared[int(np.argmax(raw))]}


def travel_error(src: Played, out: Played) -> dict:
    """The hip midpoint's ground-plane path, in leg lengths: the difference of total path lengths at the
    end as a fraction of the source's, and (stricter) the summed step-by-step displacement difference."""
    a = np.diff(src.hips()[:, [0, 2]], axis=0) / src.rig.leg
    b = np.diff(out.hips()[:, [0, 2]], axis=0) / out.rig.leg
    path = np.linalg.norm(a, axis=1).sum()
    return {"travel": float(abs(np.linalg.norm(b, axis=1).sum() - path) / path),
            "travel_steps": float(np.linalg.norm(a - b, axis=1).sum() / path), "path_legs": float(path)}


def bone_error(src: Played, out: Played) -> dict:
    """Angles (degrees) between source and result limb bones, every frame: mean and 99th percentile."""
    angles = []
    for a, b in LIMBS:
        u = src.joint(b) - src.joint(a)
        v = out.joint(b) - out.joint(a)
        cos = (u * v).sum(-1) / np.maximum(np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1), 1e-12)
        angles.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    arms = np.concatenate([x for x, (a, _) in zip(angles, LIMBS, strict=True) if "Hip" not in a and "Knee" not in a])
    legs = np.concatenate([x for x, (a, _) in zip(angles, LIMBS, strict=True) if "Hip" in a or "Knee" in a])
    every = np.concatenate(angles)
    return {"bone": float(every.mean()), "bone_p99": float(np.percentile(every, 99)),
            "bone_arms_p99": float(np.percentile(arms, 99)), "bone_legs_p99": float(np.percentile(legs, 99))}


def round_trip_error(src: Played, back: Played) -> dict:
    """Mapped joints of the take against the round trip: position error per leg length after one constant
    vertical shift (reported, per leg) and world rotation error in degrees."""
    idx = sorted(src.rig.map.joints.values())
    names = {j: c for c, j in src.rig.map.joints.items()}
    diff = back.pos[:, idx] - src.pos[:, idx]
    shift = float(np.median(diff[..., 1]))
    diff[..., 1] -= shift
    dist = np.linalg.norm(diff, axis=-1) / src.rig.leg
    dots = np.abs((src.rot[:, idx] * back.rot[:, idx]).sum(-1))
    angle = np.degrees(2 * np.arccos(np.clip(dots, 0.0, 1.0)))
    return {"pos": float(dist.mean()), "pos_max": float(dist.max()),
            "pos_max_joint": names[idx[int(np.argmax(dist.max(axis=0)))]], "rot": float(angle.mean()),
            "rot_max": float(angle.max()), "shift_legs": shift / src.rig.leg}


def timed(fn, *args, **kwargs):
    """``fn``'s result and the seconds it took."""
    start = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - start


def onto(src: Played, out: Motion, seconds: float) -> dict:
    """All measures of one result against its source."""
    res = Played.of(out)
    return (trajectory_error(src, res) | bone_error(src, res) | travel_error(src, res) | foot_measures(res)
            | {"time": seconds})


def measure_take(path: Path, rigs: dict[str, Skeleton], seed: int = 0) -> dict:
    """Every row of the benchmark for one take."""
    take = read_motion(path, "bvh").skeleton_motion
    take = take.crop(SKIP)
    src = Played.of(take)
    rows: dict[str, dict] = {"source take": foot_measures(src)}
    for name, rig in rigs.items():
        for ground in (True, False):
            out, seconds = timed(lambda r=rig, g=ground: retarget(take, r, ground=g)[0])
            rows[f"{name}{'' if ground else ', no grounding'}"] = onto(src, out, seconds)
            if name == "dance24" and ground:
                grounded_d24 = out
    out, seconds = timed(lambda: retarget(take, take.skeleton, ground=False)[0])
    rows["own skeleton, no grounding"] = onto(src, out, seconds)
    out, seconds = timed(lambda: retarget(take, narrow_shoulders(rigs["dance24"], take.skeleton), ground=False)[0])
    rows["diagnostic: dance24 with the take's shoulder width, no grounding"] = onto(src, out, seconds)
    for name, rig in rigs.items():
        out, seconds = timed(naive_retarget, take, rig)
        rows[f"control: naive onto {name}"] = onto(src, out, seconds)
    order = np.random.default_rng(seed).permutation(take.n_frames)
    shuffled = replace(take, root=take.root[order], rotations=take.rotations[order])
    out, seconds = timed(lambda: retarget(shuffled, rigs["dance24"])[0])
    rows["control: frames shuffled, onto dance24"] = onto(src, out, seconds)
    shift = int(round(SHIFT_S * take.fps))  # source frame t against result frame t + shift
    early = Played.of(take.crop(0, take.n_frames - shift))
    rows["control: dance24 result 0.5 s late"] = onto(early, grounded_d24.crop(shift), 0.0)
    trips = {}
    for ground in (False, True):
        start = time.perf_counter()
        there, report_there = retarget(take, rigs["dance24"], ground=ground)
        back, report_back = retarget(there, take.skeleton, ground=ground)
        seconds = time.perf_counter() - start
        back_played = Played.of(back, src.rig)
        row = round_trip_error(src, back_played) | {"time": seconds, "grounding_there": report_there.grounding,
                                                   "grounding_back": report_back.grounding}
        if ground:
            row |= foot_measures(back_played)
        trips["with grounding" if ground else "no grounding"] = row
    return {"take": path.stem, "frames": take.n_frames, "fps": take.fps, "seconds": take.duration,
            "rows": rows, "round_trip": trips}


# --- tables -------------------------------------------------------------------------------------------

def _stats(takes: list[dict], group: str, row: str, key: str) -> np.ndarray:
    return np.array([t[group][row][key] for t in takes if key in t[group][row]], float)


def _mean(values: np.ndarray) -> float | None:
    """Mean of the finite values, None when there are none."""
    finite = values[np.isfinite(values)]
    return float(finite.mean()) if len(finite) else None


def _fmt(x: float, digits: int = 3) -> str:
    return "–" if x is None or not np.isfinite(x) else f"{x:.{digits}f}"


def _worst_joint(takes: list[dict], row: str) -> str:
    names = [t["rows"][row]["traj_worst_joint"] for t in takes]
    top = max(sorted(set(names)), key=names.count)  # ties: the first name in alphabetical order
    return f"{top} ({names.count(top)}/{len(names)})"


def main_table(takes: list[dict]) -> str:
    """Mean over takes of each measure, one row per target / method."""
    keys = ("traj", "traj_worst", "traj_raw", "travel", "bone", "bone_p99", "skating_leg_s", "skating_cm_s",
            "contact", "below_floor", "time")
    head = ("| onto | trajectory error / leg, mean-removed: mean over joints | worst joint (takes) | its error "
            "| raw (no mean removal) | travel error | bone error mean (°) | bone p99 (°) "
            "| skating in contact (leg/s) | (cm/s) | frames in contact | frames with a foot > 1 cm under the floor "
            "| time per take (s) |")
    lines = [head, "|" + "---|" * 13]

    def pct(v: float | None) -> str:
        return "–" if v is None else f"{100 * v:.1f} %"

    for row in takes[0]["rows"]:
        m = {k: _mean(_stats(takes, "rows", row, k)) for k in keys}
        worst = _worst_joint(takes, row) if m["traj"] is not None else "–"
        lines.append(
            f"| {row} | {_fmt(m['traj'])} | {worst} | {_fmt(m['traj_worst'])} | {_fmt(m['traj_raw'])} "
            f"| {pct(m['travel'])} | {_fmt(m['bone'], 2)} | {_fmt(m['bone_p99'], 2)} | {_fmt(m['skating_leg_s'])} "
            f"| {_fmt(m['skating_cm_s'], 1)} | {pct(m['contact'])} | {pct(m['below_floor'])} "
            f"| {_fmt(m['time'], 3) if m['time'] else '–'} |")
    return "\n".join(lines)


def round_trip_table(takes: list[dict]) -> str:
    """Round trip take -> dance24 -> take: mean over takes (worst take)."""
    lines = ["| take -> dance24 -> take | position error / leg: mean | max | rotation error mean (°) | max (°) "
             "| vertical shift (leg) | skating (leg/s) | time per take (s) |", "|" + "---|" * 8]
    for row in takes[0]["round_trip"]:
        get = lambda k, r=row: _stats(takes, "round_trip", r, k)  # noqa: E731
        skate = get("skating_leg_s")
        lines.append(
            f"| {row} | {_fmt(get('pos').mean(), 4)} (worst take {_fmt(get('pos').max(), 4)}) "
            f"| {_fmt(get('pos_max').max(), 4)} | {_fmt(get('rot').mean(), 3)} (worst {_fmt(get('rot').max(), 3)}) "
            f"| {_fmt(get('rot_max').max(), 2)} | {_fmt(np.abs(get('shift_legs')).mean(), 4)} "
            f"(worst {_fmt(np.abs(get('shift_legs')).max(), 4)}) "
            f"| {_fmt(skate.mean()) if len(skate) else '–'} | {_fmt(get('time').mean(), 3)} |")
    return "\n".join(lines)


#: (measure, key, the engine row it is compared with, the controls that must fail it)
SEPARATION = [
    ("trajectory error / leg, mean-removed, mean over joints", "traj", "mixamo A-pose cm",
     ["control: naive onto mixamo A-pose cm"]),
    ("trajectory error / leg, mean-removed, mean over joints", "traj", "dance24",
     ["control: frames shuffled, onto dance24", "control: dance24 result 0.5 s late"]),
    ("trajectory error / leg, mean-removed, worst joint", "traj_worst", "mixamo A-pose cm",
     ["control: naive onto mixamo A-pose cm"]),
    ("trajectory error / leg, mean-removed, worst joint", "traj_worst", "dance24",
     ["control: frames shuffled, onto dance24", "control: dance24 result 0.5 s late"]),
    ("bone direction error p99 (°)", "bone_p99", "mixamo A-pose cm", ["control: naive onto mixamo A-pose cm"]),
    ("bone direction error p99 (°)", "bone_p99", "dance24",
     ["control: frames shuffled, onto dance24", "control: dance24 result 0.5 s late"]),
    ("travel error", "travel", "mixamo A-pose cm", ["control: naive onto mixamo A-pose cm"]),
    ("travel error", "travel", "dance24", ["control: naive onto dance24", "control: frames shuffled, onto dance24"]),
    ("skating in contact (leg/s)", "skating_leg_s", "mixamo A-pose cm", ["control: naive onto mixamo A-pose cm"]),
    ("skating in contact (leg/s)", "skating_leg_s", "dance24", ["control: naive onto dance24"]),
]
#: a control fails a measure when, on every take, it scores at least this many times the engine on that take
#: (or this many times the measure's floor, where the engine's error is below it: 0 is no yardstick)
FAIL_RATIO = 1.5
FLOOR = {"traj": 0.01, "traj_worst": 0.02, "bone_p99": 2.0, "travel": 0.05, "skating_leg_s": 0.02}


def separation_table(takes: list[dict]) -> str:
    """For each measure and control: the engine's and the control's mean over takes (worst and best take),
    and the control's error divided by the engine's on the same take (by ``FLOOR`` where the engine's is
    smaller), smallest over takes."""
    lines = ["| measure | engine row | control | engine, mean (worst take) | control, mean (best take) "
             f"| control ÷ engine (or floor), same take, smallest | fails on every take (≥ {FAIL_RATIO}×)? |",
             "|---|---|---|---|---|---|---|"]
    for label, key, engine, controls in SEPARATION:
        digits = 2 if key.startswith("bone") else 4
        e = _stats(takes, "rows", engine, key)
        for c in controls:
            v = _stats(takes, "rows", c, key)
            ok = np.isfinite(v)
            if not ok.any():
                lines.append(f"| {label} | {engine} | {c.removeprefix('control: ')} | {_fmt(e.mean(), digits)} "
                             f"({_fmt(e.max(), digits)}) | – | – | no contact found in any take |")
                continue
            small = float((v[ok] / np.maximum(e[ok], FLOOR[key])).min())
            times = f"{small:.1f}×" if small < 1000 else "> 1000×"
            note = f" (no contact in {int((~ok).sum())} takes)" if not ok.all() else ""
            lines.append(f"| {label} | {engine} | {c.removeprefix('control: ')} | {_fmt(e.mean(), digits)} "
                         f"({_fmt(e.max(), digits)}) | {_fmt(v[ok].mean(), digits)} ({_fmt(v[ok].min(), digits)}) "
                         f"| {times} | {'yes' if small >= FAIL_RATIO else 'NO'}{note} |")
    return "\n".join(lines)


JOINT_ROWS = ("dance24, no grounding", "diagnostic: dance24 with the take's shoulder width, no grounding", "dance24",
              "control: naive onto mixamo A-pose cm")


def joint_table(takes: list[dict], rows: tuple[str, ...] = JOINT_ROWS) -> str:
    """Mean-removed trajectory error per leg of each canonical joint, mean over takes."""
    joints = list(takes[0]["rows"][rows[0]]["traj_joints"])
    lines = ["| joint | " + " | ".join(rows) + " |", "|" + "---|" * (len(rows) + 1)]
    for j in joints:
        cells = [_fmt(np.mean([t["rows"][r]["traj_joints"][j] for t in takes])) for r in rows]
        lines.append(f"| {j} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def per_take_table(takes: list[dict]) -> str:
    """One line per take, grounded dance24 and Mixamo rows and the round trip."""
    lines = ["| take | frames | fps | dance24 traj | worst joint | bone p99 | skating src → d24 (leg/s) "
             "| mixamo traj | bone p99 | round trip pos / leg |", "|" + "---|" * 10]
    for t in takes:
        d, mx, s = t["rows"]["dance24"], t["rows"]["mixamo A-pose cm"], t["rows"]["source take"]
        lines.append(f"| {t['take']} | {t['frames']} | {t['fps']:g} | {_fmt(d['traj'])} | {d['traj_worst_joint']} "
                     f"| {_fmt(d['bone_p99'], 2)} | {_fmt(s['skating_leg_s'])} → {_fmt(d['skating_leg_s'])} "
                     f"| {_fmt(mx['traj'])} | {_fmt(mx['bone_p99'], 2)} "
                     f"| {_fmt(t['round_trip']['no grounding']['pos'], 5)} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Measure every take, print the tables (and write the JSON when asked)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mocap", type=Path, default=DATA, help="folder of CMU dance BVH takes")
    ap.add_argument("--only", default="*.bvh", help="glob of takes inside the folder (default: all)")
    ap.add_argument("--json", metavar="FILE", help="also write every per-take figure as JSON ('-': stdout)")
    ap.add_argument("--per-take", action="store_true", help="also print one line per take")
    args = ap.parse_args(argv)
    paths = sorted(args.mocap.glob(args.only))
    if not paths:
        print(f"no BVH takes matching {args.only!r} in {args.mocap}", file=sys.stderr)
        return 1
    rigs = {"dance24": dance24(), "mixamo A-pose cm": mixamo_rig()}
    start = time.perf_counter()
    takes = []
    for path in paths:
        takes.append(measure_take(path, rigs))
        print(f"{path.stem}: {takes[-1]['frames']} frames", file=sys.stderr, flush=True)
    wall = time.perf_counter() - start
    minutes = sum(t["seconds"] for t in takes) / 60
    print(f"{len(takes)} takes ({minutes:.1f} min of motion, {SKIP} leading frames dropped each) in {wall:.0f} s\n")
    print(main_table(takes), "\n")
    print(round_trip_table(takes), "\n")
    print(separation_table(takes), "\n")
    print(joint_table(takes))
    if args.per_take:
        print("\n" + per_take_table(takes))
    if args.json:
        text = json.dumps({"takes": takes, "wall_s": wall}, indent=1, default=float)
        if args.json == "-":
            print(text)
        else:
            Path(args.json).write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
