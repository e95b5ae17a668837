"""Real motion capture (CMU dance takes): are the salsa takes 60 or 120 fps, and how do the CMU skeleton's
proportions compare with our default ``dance24``?

    .venv/bin/python benchmarks/mocap_frame_rate.py [FOLDER] [--fixture PATH]

FOLDER defaults to ``../shared/mocap/cmu-dance`` relative to the repository root (read in place, never
copied); ``--fixture`` defaults to ``../shared/fixtures/bvh/cmu_01_01.bvh`` (CMU subject 1, forward jumps,
known 120 fps), used to check the gravity method; it is skipped when absent. numpy only, one process,
about 15 s on a 2-core VM. Prints the figures quoted in docs/mocap.md.

The frame-rate check never assumes the answer: every rate-dependent figure is printed twice, once as if
the salsa files were 60 fps and once as if 120 fps, next to the modern-dance takes of the same database
(subject 5, known 120 fps) and to what people do (walking, running, salsa music). Physical smoothing
windows are set in seconds under each hypothesis. Lengths are in leg lengths (standing hip-joint height
above the floor, measured per take), so the salsa files' rescaled units cancel; accelerations are turned
into g with an assumed leg length of ``LEG_M`` metres (the gravity fit on subject 1 gives 0.89 m).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / ".." / "shared" / "mocap" / "cmu-dance"
FIXTURE = ROOT / ".." / "shared" / "fixtures" / "bvh" / "cmu_01_01.bvh"
LEG_M = 0.90  # assumed standing hip-joint height, metres (adult; Winter 0.53 x 1.70 m; subject 1 by gravity: 0.89)
G = 9.81
SKIP = 10  # leading frames dropped: the conversion's T-pose and a start-up transient (~8 frames)
RATES = (60, 120)

#: body-part roles -> joint names, for the two namings used (cgspeed "Daz-friendly" and cgspeed/fairmotion CMU)
ROLES = {
    "daz": dict(
        root="hip",
        hips=("rThigh", "lThigh"),
        shoulders=("rShldr", "lShldr"),
        head="head",
        feet=(("rFoot", "rFoot_end"), ("lFoot", "lFoot_end")),
        ankles=("rFoot", "lFoot"),
        upper_arm=(("rShldr", "rForeArm"), ("lShldr", "lForeArm")),
        forearm=(("rForeArm", "rHand"), ("lForeArm", "lHand")),
        hand=(("rHand", "rMid1"), ("lHand", "lMid1")),
        thigh=(("rThigh", "rShin"), ("lThigh", "lShin")),
        shank=(("rShin", "rFoot"), ("lShin", "lFoot")),
        foot=(("rFoot", "rFoot_end"), ("lFoot", "lFoot_end")),
        hands=("rHand", "lHand"),
    ),
    "cmu": dict(
        root="Hips",
        hips=("RightUpLeg", "LeftUpLeg"),
        shoulders=("RightArm", "LeftArm"),
        head="Head",
        feet=(("RightFoot", "RightToeBase", "RightToeBase_end"), ("LeftFoot", "LeftToeBase", "LeftToeBase_end")),
        ankles=("RightFoot", "LeftFoot"),
        upper_arm=(("RightArm", "RightForeArm"), ("LeftArm", "LeftForeArm")),
        forearm=(("RightForeArm", "RightHand"), ("LeftForeArm", "LeftHand")),
        hand=(("RightHand", "RightFingerBase"), ("LeftHand", "LeftFingerBase")),
        thigh=(("RightUpLeg", "RightLeg"), ("LeftUpLeg", "LeftLeg")),
        shank=(("RightLeg", "RightFoot"), ("LeftLeg", "LeftFoot")),
        foot=(("RightFoot", "RightToeBase_end"), ("LeftFoot", "LeftToeBase_end")),
        hands=("RightHand", "LeftHand"),
    ),
}
#: Winter (2009) Table 4.1: segment mass fraction, centre of mass from the proximal end (fraction of length)
SEGMENTS = (
    ("upper_arm", 0.028, 0.436),
    ("forearm", 0.016, 0.430),
    ("hand", 0.006, 0.506),
    ("thigh", 0.100, 0.433),
    ("shank", 0.0465, 0.433),
    ("foot", 0.0145, 0.5),
)
TRUNK, HEAD_NECK = 0.497, 0.081


class Take:
    """One BVH take: world positions (T, J+E, 3) with End Sites named ``<parent>_end``, header fps, leg length."""

    def __init__(self, path: Path):
        from dance_core.api import read_motion

        motion = read_motion(path, "bvh").skeleton_motion
        skel = motion.skeleton
        self.name, self.header_fps, self.skeleton = path.stem, float(motion.fps), skel
        self.frames = motion.positions(end_sites=True).shape[0]
        self.pos = motion.positions(end_sites=True)[SKIP:].astype(float)
        self.names = list(skel.names) + [skel.names[j] + "_end" for j in sorted(skel.end_sites)]
        self.roles = ROLES["daz" if "hip" in skel.names else "cmu"]
        lowest = self.foot_heights().min(1)
        self.floor = float(np.percentile(lowest, 5))
        self.leg = float(np.median(self.p(*self.roles["hips"]).mean(1)[:, 1]) - self.floor)

    def p(self, *names: str) -> np.ndarray:
        """Positions of the named joints, (T, n, 3)."""
        return self.pos[:, [self.names.index(n) for n in names]]

    def foot_heights(self) -> np.ndarray:
        """Lowest point of each foot (ankle, toe joints, toe end), (T, 2)."""
        return np.stack([self.p(*pts)[..., 1].min(1) for pts in self.roles["feet"]], 1)

    def com(self) -> np.ndarray:
        """Whole-body centre of mass (T, 3) from Winter's segment masses (trunk between hip and shoulder centres)."""
        r = self.roles
        hip, sh = self.p(*r["hips"]).mean(1), self.p(*r["shoulders"]).mean(1)
        c = TRUNK * (hip + sh) / 2 + HEAD_NECK * self.p(r["head"])[:, 0]
        for seg, mass, at in SEGMENTS:
            for a, b in r[seg]:
                pa, pb = self.p(a)[:, 0], self.p(b)[:, 0]
                c = c + mass * (pa + at * (pb - pa))
        return c


def smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian smoothing along axis 0 (``sigma`` in frames), edges padded."""
    r = max(1, int(np.ceil(4 * sigma)))
    w = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    w /= w.sum()
    xp = np.pad(x, [(r, r)] + [(0, 0)] * (x.ndim - 1), mode="edge")
    flat = xp.reshape(len(xp), -1)
    return np.stack([np.convolve(flat[:, i], w, mode="valid") for i in range(flat.shape[1])], 1).reshape(x.shape)


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of each run of True."""
    edges = np.diff(np.r_[0, mask.astype(int), 0])
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def accel_g(x: np.ndarray, fps: float, leg: float, window_s: float = 0.03) -> np.ndarray:
    """Second derivative in g of a (T, ...) trajectory in file units, if the file were ``fps``: Gaussian
    smoothing of ``window_s`` seconds (sigma), lengths turned into metres through the leg length."""
    return np.diff(smooth(x, window_s * fps), 2, axis=0) * fps**2 / leg * LEG_M / G


def steps(take: Take, v_on: float = 0.008, min_path: float = 0.08) -> int:
    """Foot movements: runs where an ankle moves faster than ``v_on`` leg lengths per frame covering at least
    ``min_path`` leg lengths (counted in frames, so the count itself does not depend on the frame rate)."""
    ank = smooth(take.p(*take.roles["ankles"]) / take.leg, 1.5)
    speed = np.linalg.norm(np.diff(ank, axis=0), axis=-1)
    return sum(1 for j in range(2) for s, e in runs(speed[:, j] > v_on) if speed[s:e, j].sum() >= min_path)


def foot_speed_signal(take: Take) -> np.ndarray:
    """Both ankles' speeds summed, leg lengths per frame, mean removed."""
    ank = smooth(take.p(*take.roles["ankles"]) / take.leg, 1.5)
    x = np.linalg.norm(np.diff(ank, axis=0), axis=-1).sum(1)
    return x - x.mean()


def autocorr(x: np.ndarray, n: int) -> np.ndarray:
    f = np.fft.rfft(x, 2 * len(x))
    ac = np.fft.irfft(np.abs(f) ** 2)[:n]
    return ac / ac[0]


def peaks(y: np.ndarray, lo: int) -> list[int]:
    return [i for i in range(max(lo, 1), len(y) - 1) if y[i] > y[i - 1] and y[i] >= y[i + 1]]


def flights(take: Take, fps: float) -> list[tuple[int, int, float, float]]:
    """Both feet off the floor (> 0.08 leg) for >= 12 frames: a parabola fitted to the centre of mass inside
    (2 frames trimmed each end). Returns (start, frames, downward acceleration in leg lengths/s^2, fit rms/leg)."""
    com, out = take.com()[:, 1], []
    for s, e in runs(take.foot_heights().min(1) > take.floor + 0.08 * take.leg):
        if not 12 <= e - s <= 90:
            continue
        t = np.arange(e - s - 4)
        y = com[s + 2 : e - 2]
        c = np.polyfit(t, y, 2)
        out.append((int(s), int(e - s), -2 * c[0] * fps**2 / take.leg, float(np.std(y - np.polyval(c, t)) / take.leg)))
    return out


def rng(vals) -> str:
    v = np.asarray(list(vals), float)
    return f"{v.min():.2f}-{v.max():.2f}"


def frame_rate_check(folder: Path, fixture: Path | None) -> None:
    """Print the evidence on the salsa takes' frame rate."""
    takes = {p.stem: Take(p) for p in sorted(folder.glob("*.bvh"))}
    salsa = {k: t for k, t in takes.items() if k.startswith("salsa")}
    modern = {k: t for k, t in takes.items() if k.startswith("modern")}
    groups = {
        "salsa_60": [t for k, t in salsa.items() if "_60_" in k],
        "salsa_61": [t for k, t in salsa.items() if "_61_" in k],
    }
    # modern takes whose feet move impossibly fast (> 15 leg/s at their true 120 fps) hold tracking glitches
    foot99 = {}
    for k, t in takes.items():
        ank = smooth(t.p(*t.roles["ankles"]) / t.leg, 1.5)
        foot99[k] = float(np.percentile(np.linalg.norm(np.diff(ank, axis=0), axis=-1), 99))
    clean = [t for k, t in modern.items() if foot99[k] * 120 <= 15]
    glitchy = sorted(k for k in modern if foot99[k] * 120 > 15)
    groups["modern"] = clean
    print(f"== files: {folder}")
    hdr = sorted({(k.rsplit("_", 1)[0], t.header_fps) for k, t in takes.items()})
    print("header fps:", ", ".join(f"{g} {f:g}" for g, f in hdr))
    pairs = sorted({k.split("_")[2] for k in salsa})
    same = [takes[f"salsa_60_{n}"].frames == takes[f"salsa_61_{n}"].frames for n in pairs]
    print(
        f"couple takes with equal frame counts (60 vs 61): {sum(same)}/{len(pairs)}; "
        f"salsa takes {min(t.frames for t in salsa.values())}-{max(t.frames for t in salsa.values())} frames "
        f"= {min(t.frames for t in salsa.values()) / 60:.0f}-{max(t.frames for t in salsa.values()) / 60:.0f} s "
        "at 60 fps"
    )
    hand_d = []
    for n in pairs:
        a, b = takes[f"salsa_60_{n}"], takes[f"salsa_61_{n}"]
        ha, hb = a.p(*a.roles["hands"]), b.p(*b.roles["hands"])
        d = np.linalg.norm(ha[:, :, None] - hb[:, None], axis=-1).reshape(len(ha), -1).min(1) / a.leg
        hand_d.append((np.median(d), np.mean(d < 0.3)))
    hand_d = np.array(hand_d)
    print(
        f"partners' nearest hands (one world frame?): median distance {rng(hand_d[:, 0])} leg, "
        f"within 0.3 leg in {rng(100 * hand_d[:, 1])} % of frames"
    )
    print(
        f"leg length (hip joint above floor), file units: salsa {rng(t.leg for t in salsa.values())}, "
        f"modern {rng(t.leg for t in modern.values())}; modern takes left out of the references (feet > 15 leg/s "
        f"at 120 fps = tracking glitches): {', '.join(glitchy) or 'none'}"
    )

    print(
        "\n== (c) upsampled / duplicated frames? even/odd mean |2nd difference| (1.0 = none; linear upsampling "
        "gives ~0 on every other frame), fraction of repeated frames"
    )
    for g, ts in groups.items():
        ratios, dups = [], []
        for t in ts:
            d2 = np.linalg.norm(np.diff(t.pos, 2, axis=0), axis=-1).mean(1)
            ratios.append(d2[0::2].mean() / d2[1::2].mean())
            dups.append(np.mean(np.abs(np.diff(t.pos, axis=0)).max(axis=(1, 2)) == 0))
        print(f"  {g:9s} even/odd {rng(ratios)}  repeated frames {max(dups):.3f}")

    if fixture is not None and fixture.exists():
        fx = Take(fixture)
        fl = [f for f in flights(fx, 120) if f[3] < 3e-3]
        gl = np.array([f[2] for f in fl])
        print(
            f"\n== gravity calibration on {fixture.name} (subject 1, forward jumps, known 120 fps): "
            f"{len(fl)} flights, "
            f"centre-of-mass parabola {np.median(gl):.1f} leg/s^2 -> leg length g/a = {G / np.median(gl):.2f} m "
            f"({rng(G / gl)}) if 120 fps; {G / np.median(gl) * 4:.2f} m if it were 60 fps"
        )
        cand = [(t.name, f) for t in salsa.values() for f in flights(t, 60)]
        print(
            f"   salsa: {len(cand)} stretches with both feet > 0.08 leg off the floor for >= 12 frames: "
            + "; ".join(
                f"{k} {f[1]} frames, downward {f[2] * LEG_M / G:+.2f} g @60 / "
                f"{4 * f[2] * LEG_M / G:+.2f} g @120,"
                f" fit rms {1000 * f[3]:.1f}e-3 leg"
                for k, f in cand
            )
        )
        print(
            "   none falls at 1 g at either rate (supported, not flights): no free fall to time in the salsa;"
            " gravity enters through the force bounds below"
        )

    print("\n== (a) steps and tempo")
    lags = {}
    for g, ts in groups.items():
        rate = [steps(t) / (len(t.pos) - 1) for t in ts]
        sens = [[steps(t, v) / (len(t.pos) - 1) for t in ts] for v in (0.004, 0.016)]
        print(
            f"  {g:9s} foot movements (>= 0.08 leg) per 100 frames {rng(100 * np.array(rate))} "
            f"(threshold x0.5: {rng(100 * np.array(sens[0]))}, x2: {rng(100 * np.array(sens[1]))}); "
            f"both feet, steps/s: @60 {rng(60 * np.array(rate))}  @120 {rng(120 * np.array(rate))}"
        )
        if g.startswith("salsa"):
            lags[g] = np.mean([autocorr(foot_speed_signal(t), 400) for t in ts], 0)
    ac = np.mean(list(lags.values()), 0)
    pk = [i for i in peaks(ac, 20) if ac[i] > 0.05]
    print("  salsa foot-speed autocorrelation peaks (lag frames: r): " + ", ".join(f"{i}: {ac[i]:.2f}" for i in pk[:8]))
    long = [i for i in pk if i > 60]
    ks = np.array([round(i / long[0] * 2) for i in long])
    period = float(np.sum(np.array(long) * ks) / np.sum(ks * ks)) * 2  # fit lag = k * period / 2
    per_frame = np.mean([steps(t) / (len(t.pos) - 1) for ts in (groups["salsa_60"], groups["salsa_61"]) for t in ts])
    print(
        f"  -> fundamental {period / 2:.1f} frames (peaks at {', '.join(str(i) for i in long)} = "
        f"{', '.join(str(k) for k in ks)} x {period / 2:.1f}); "
        f"foot movements in {period:.0f} frames: {per_frame * period:.2f}"
    )
    print(
        f"     salsa moves the travelling foot on beats 1, 3, 5, 7 (in-place weight changes on 2, 6; still on 4, 8),"
        f" so {period / 2:.1f} frames = 2 beats: tempo @60 {60 * 2 / (period / 2 / 60):.0f} BPM, "
        f"@120 {60 * 2 / (period / 2 / 120):.0f} BPM. (If instead {period / 2:.1f} frames were one beat at 120 fps,"
        f" {per_frame * period / 2:.2f} foot movements per beat against salsa's 0.75 steps per beat, in-place ones"
        f" included; @60: {per_frame * period / 4:.2f} per beat.)"
    )

    print("\n== (b) speeds, leg lengths per second (x 0.9 ~ m/s), range over takes")
    for g, ts in groups.items():
        root = [
            np.linalg.norm(np.diff(smooth(t.p(t.roles["root"])[:, 0, [0, 2]] / t.leg, 3.0), axis=0), axis=-1)
            for t in ts
        ]
        foot = [foot99[t.name] for t in ts]
        hand = [
            np.percentile(np.linalg.norm(np.diff(smooth(t.p(*t.roles["hands"]) / t.leg, 1.5), axis=0), axis=-1), 99)
            for t in ts
        ]
        extent = [np.ptp(smooth(t.p(t.roles["root"])[:, 0, [0, 2]] / t.leg, 3.0), axis=0).max() for t in ts]
        fps = (60, 120) if g.startswith("salsa") else (120,)
        print(
            f"  {g:9s} "
            + "  ".join(
                f"@{f}: root mean {rng(f * np.array([r.mean() for r in root]))}, root p95 "
                f"{rng(f * np.array([np.percentile(r, 95) for r in root]))}, ankle p99 {rng(f * np.array(foot))}, "
                f"hand p99 {rng(f * np.array(hand))}"
                for f in fps
            )
            + f"; travel extent {rng(extent)} leg"
        )

    print(f"\n== gravity and friction bounds: centre-of-mass acceleration in g (30 ms Gaussian, leg = {LEG_M} m)")
    print(
        "   |horizontal| must stay below the floor friction coefficient (~0.3-0.6 for dance shoes, <~1 rubber);"
        " vertical cannot go below -1 g except in flight (then exactly -1 g)"
    )

    def acc_rows(ts, fps):
        rows = []
        for t in ts:
            a = accel_g(t.com(), fps, t.leg)
            ah = np.linalg.norm(a[:, [0, 2]], axis=1)
            rows.append((np.percentile(ah, 95), np.mean(ah > 0.8), np.percentile(a[:, 1], 1)))
        return np.array(rows)

    for g, ts in groups.items():
        fps = (60, 120) if g.startswith("salsa") else (120,)
        print(
            f"  {g:9s} "
            + "  ".join(
                f"@{f}: |a_h| p95 {rng(r[:, 0])}, time > 0.8 g {rng(100 * r[:, 1])} %, a_y p1 {rng(r[:, 2])}"
                for f in fps
                for r in [acc_rows(ts, f)]
            )
        )
    if fixture is not None and fixture.exists():
        r = acc_rows([fx], 120)
        print(
            f"  {fixture.stem:9s} @120: |a_h| p95 {r[0, 0]:.2f}, time > 0.8 g {100 * r[0, 1]:.1f} %, "
            f"a_y p1 {r[0, 2]:.2f}"
            " (includes ~10 jumps)"
        )
    couple = []
    for n in pairs:
        a, b = takes[f"salsa_60_{n}"], takes[f"salsa_61_{n}"]
        c = (a.com() + b.com()) / 2  # equal masses assumed; partners' pulls on each other cancel
        row = []
        for f in RATES:
            acc = accel_g(c, f, (a.leg + b.leg) / 2)
            row.append(np.percentile(np.linalg.norm(acc[:, [0, 2]], axis=1), 99))
        couple.append(row)
    couple = np.array(couple)
    print(
        f"  couple's joint centre of mass (internal forces cancel; only floor friction moves it): |a_h| p99 "
        f"@60 {rng(couple[:, 0])}, @120 {rng(couple[:, 1])}"
    )

    print(
        "\n== (c) spectra of root-relative joint positions (Welch, 256 frames): where the power has fallen"
        " 40 dB below its peak, and the level at the Nyquist frequency"
    )
    for g, ts in groups.items():
        knee, nyq = [], []
        for t in ts:
            x = (t.pos - t.pos[:, :1]).reshape(len(t.pos), -1) / t.leg
            n, w = 256, np.hanning(256)
            P = np.mean(
                [
                    np.abs(np.fft.rfft((x[s : s + n] - x[s : s + n].mean(0)) * w[:, None], axis=0)) ** 2
                    for s in range(0, len(x) - n + 1, n // 2)
                ],
                0,
            ).sum(1)
            P = P / P.max()
            knee.append(np.fft.rfftfreq(n)[np.argmax(P < 1e-4)])
            nyq.append(10 * np.log10(P[-1]))
        knee = np.array(knee)
        fps = (60, 120) if g.startswith("salsa") else (120,)
        print(
            f"  {g:9s} -40 dB at {rng(knee)} cycles/frame = "
            + ", ".join(f"@{f}: {rng(knee * f)} Hz" for f in fps)
            + f"; Nyquist level {rng(nyq)} dB (no flat noise floor: the data were smoothed)"
        )
    print(f"  {'':9s} human movement content ends by ~6-10 Hz (Winter's 6 Hz gait filter): both rates fit, not a test")


def _rest(skel) -> tuple[np.ndarray, dict[str, int]]:
    rest = skel.rest_positions()
    names = list(skel.names)
    ends = [rest[j] + skel.end_sites[j] for j in sorted(skel.end_sites)]
    names += [skel.names[j] + "_end" for j in sorted(skel.end_sites)]
    return np.vstack([rest] + ends), {n: i for i, n in enumerate(names)}


PROPORTION_ROWS = (
    "thigh",
    "shank",
    "upper arm",
    "forearm",
    "foot (ankle-toe end)",
    "hip width",
    "shoulder width",
    "hip centre-neck",
    "leg (hip joint-floor)",
    "height",
)


def _measures(pos: np.ndarray, ix: dict[str, int], m: dict[str, str], top: float) -> dict[str, float]:
    """Segment lengths from rest positions, by the joint names in ``m``; ``top`` is the standing height."""

    def d(a: str, b: str) -> float:
        return float(np.linalg.norm(pos[ix[m[a]]] - pos[ix[m[b]]]))

    floor = min(pos[ix[m["toe_r"]], 1], pos[ix[m["toe_l"]], 1], pos[ix[m["ankle"]], 1])
    hip = (pos[ix[m["hip_r"]]] + pos[ix[m["hip_l"]]]) / 2
    return {
        "thigh": d("hip_r", "knee"),
        "shank": d("knee", "ankle"),
        "upper arm": d("shoulder", "elbow"),
        "forearm": d("elbow", "wrist"),
        "foot (ankle-toe end)": d("ankle", "toe_r"),
        "hip width": d("hip_r", "hip_l"),
        "shoulder width": d("shoulder", "shoulder_l"),
        "hip centre-neck": float(np.linalg.norm(pos[ix[m["neck"]]] - hip)),
        "leg (hip joint-floor)": float(hip[1] - floor),
        "height": top,
    }


def proportions(folder: Path) -> None:
    """Print body proportions of each CMU subject's rest pose and of dance24, as fractions of leg and height."""
    from dance_core.api import read_motion
    from dance_core.motion import dance24

    cmu_map = dict(
        hip_r="rThigh",
        hip_l="lThigh",
        knee="rShin",
        ankle="rFoot",
        toe_r="rFoot_end",
        toe_l="lFoot_end",
        shoulder="rShldr",
        shoulder_l="lShldr",
        elbow="rForeArm",
        wrist="rHand",
        neck="neck",
    )
    cols = {}
    offsets = {}
    for subject, take in (("60", "salsa_60_01"), ("61", "salsa_61_01"), ("5", "modern_05_02")):
        skel = read_motion(folder / f"{take}.bvh", "bvh").skeleton_motion.skeleton
        pos, ix = _rest(skel)
        floor = pos[ix["rFoot_end"], 1]
        eye = (pos[ix["leftEye_end"], 1] + pos[ix["rightEye_end"], 1]) / 2 - floor
        cols[f"CMU {subject}"] = _measures(pos, ix, cmu_map, eye / 0.936)  # no head-top End Site: Winter's eye height
        offsets[subject] = np.asarray(skel.offsets, float)
    ratio = np.linalg.norm(offsets["5"], axis=1).sum() / np.linalg.norm(offsets["60"], axis=1).sum()
    same = [
        np.allclose(offsets[s] * (ratio if s != "5" else 1), offsets["5"], rtol=1e-3, atol=1e-4) for s in ("60", "61")
    ]
    d24 = dance24(1.0)
    pos, ix = _rest(d24)
    d_map = dict(
        hip_r="R_Hip",
        hip_l="L_Hip",
        knee="R_Knee",
        ankle="R_Ankle",
        toe_r="R_Foot_end",
        toe_l="L_Foot_end",
        shoulder="R_Shoulder",
        shoulder_l="L_Shoulder",
        elbow="R_Elbow",
        wrist="R_Wrist",
        neck="Neck",
    )
    cols["dance24"] = _measures(pos, ix, d_map, float(pos[ix["Head_end"], 1] - min(pos[:, 1])))
    print(
        "== proportions (rest pose). CMU files: the three subjects' offsets are the same template "
        f"(subject 60 and 61 offsets x {ratio:.1f} == subject 5's: {same}); CMU height = eye height / 0.936"
    )
    names = list(cols)
    print(f"  {'':24s}" + "".join(f"{n + ' /leg':>13s}{n + ' /H':>12s}" for n in names) + f"{'CMU/d24':>9s}")
    for row in PROPORTION_ROWS:
        vals = []
        for n in names:
            c = cols[n]
            vals += [c[row] / c["leg (hip joint-floor)"], c[row] / c["height"]]
        print(
            f"  {row:24s}"
            + "".join(f"{v:13.3f}{w:12.3f}" for v, w in zip(vals[0::2], vals[1::2], strict=True))
            + f"{vals[0] / vals[-2]:9.2f}"
        )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder", nargs="?", type=Path, default=DATA)
    ap.add_argument("--fixture", type=Path, default=FIXTURE)
    args = ap.parse_args(argv)
    if not args.folder.is_dir():
        sys.exit(f"no such folder: {args.folder}")
    np.set_printoptions(precision=3, suppress=True)
    frame_rate_check(args.folder, args.fixture)
    print()
    proportions(args.folder)


if __name__ == "__main__":
    main()
