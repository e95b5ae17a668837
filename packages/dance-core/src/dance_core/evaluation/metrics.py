"""The registered metrics: each scores a set of generated ``JointClip``s (see ``protocols.Metric``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.evaluation import beats as B
from dance_core.evaluation.canon import canonical_windows, hip_indices, sliding_windows
from dance_core.evaluation.clips import check_positions, require_clips, require_frames, same_joint_count
from dance_core.evaluation.contact import SCALE, foot_indices, pfc_clip
from dance_core.evaluation.frechet import average_pairwise_distance, normalize, set_distance
from dance_core.evaluation.freezing import auc, max_joint_speed, pff_curve
from dance_core.evaluation.geometric import geometric_features
from dance_core.evaluation.kinetic import kinetic_features
from dance_core.evaluation.quality import CONTROL_TEMPO, beat_locking
from dance_core.protocols import JointClip, MetricResult

FEATURE_KINDS: dict[str, tuple[str, Callable[[JointClip, bool], np.ndarray]]] = {
    "kinetic": ("k", kinetic_features),
    "geometric": ("g", geometric_features),
}


def feature_matrix(clips: Sequence[JointClip], kind: str, compat: bool) -> np.ndarray:
    """Stacked per-clip features ``(N, D)`` of one kind (one joint count across the clips)."""
    counts = sorted({np.shape(c.positions)[1] for c in clips if np.ndim(c.positions) == 3})
    if len(counts) > 1:
        raise DataError(f"{kind} features: the clips have different joint counts {counts}")
    fn = FEATURE_KINDS[kind][1]
    return np.stack([fn(c, compat) for c in clips])


class FeatureFID:
    """FID_k / FID_g: Fréchet distance of kinetic or geometric features, normalized by the reference."""

    needs = ("reference",)

    def __init__(self, kind: str, compat: bool = False):
        self.kind, self.compat = kind, compat
        self.value = f"FID_{FEATURE_KINDS[kind][0]}"

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Score the generated set against the reference set."""
        require_clips(generated, 2, self.value)
        require_clips(reference, 2, self.value, "reference")
        same_joint_count(generated, reference, self.value)
        ref, gen = normalize(
            feature_matrix(reference, self.kind, self.compat),
            feature_matrix(generated, self.kind, self.compat),
            compat=self.compat,
        )
        return MetricResult({self.value: set_distance(gen, ref, self.value)})


class FeatureDiversity:
    """Div_k / Div_g: mean pairwise distance of normalized features within the generated set."""

    needs: tuple[str, ...] = ()

    def __init__(self, kind: str, compat: bool = False):
        self.kind, self.compat = kind, compat
        self.value = f"Div_{FEATURE_KINDS[kind][0]}"

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Normalize with the reference's statistics (or the generated set's own, with a note)."""
        require_clips(generated, 2, self.value)
        gen, notes = normalized_features(generated, reference, self.kind, self.compat, self.value)
        return MetricResult({self.value: average_pairwise_distance(gen, self.value)}, notes=notes)


def normalized_features(
    generated: Sequence[JointClip], reference: Sequence[JointClip] | None, kind: str, compat: bool, what: str
) -> tuple[np.ndarray, list[str]]:
    """The generated set's features normalized with the reference's statistics, else its own (with a note)."""
    gen = feature_matrix(generated, kind, compat)
    if reference:
        same_joint_count(generated, reference, what)
        return normalize(feature_matrix(reference, kind, compat), gen, compat=compat)[1], []
    note = f"{what}: no reference set; features normalized by the generated set"
    return normalize(gen, compat=compat)[0], [note]


def with_music(
    clips: Sequence[JointClip], what: str
) -> tuple[list[tuple[JointClip, np.ndarray, np.ndarray]], list[str]]:
    """Clips usable for a beat metric as (clip, positions, music beats within the clip), plus notes.

    Clips without music beats or too short to have a motion beat are skipped with a note; a
    DataError when none is left.
    """
    if not any(c.music_beats is not None for c in clips):
        raise DataError(f"{what} needs music beats: pass --music DIR (songs or .beats files)")
    usable, notes = [], []
    for clip in clips:
        p = check_positions(clip)
        if clip.music_beats is None:
            notes.append(f"{what}: {clip.name}: no music found; skipped")
            continue
        music = B.beats_within(clip.music_beats, clip.duration)
        if len(music) == 0:
            notes.append(f"{what}: {clip.name}: no music beat within its {clip.duration:.2f} s; skipped")
            continue
        if len(p) < 3:
            notes.append(f"{what}: {clip.name}: {len(p)} frames are too few for motion beats; skipped")
            continue
        usable.append((clip, p, music))
    if not usable:
        reasons = "; ".join(n.removeprefix(f"{what}: ") for n in notes)
        raise DataError(f"{what}: no clip has both motion and music beats ({reasons})")
    return usable, notes


def _no_beat_note(what: str, clip: JointClip) -> str:
    return f"{what}: {clip.name}: no motion beat (constant or frozen motion?); scored 0"


class BailandoBAS:
    """Bailando's Beat Align Score: mean over music beats of the Gaussian distance to a motion beat."""

    needs = ("music",)

    def __init__(self, smooth_seconds: float = 5 / 60, sigma_seconds: float = 3 / 60):
        self.smooth, self.sigma = smooth_seconds, sigma_seconds

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Mean over clips of the per-clip score."""
        usable, notes = with_music(generated, "BAS_bailando")
        per_clip = {}
        for clip, p, music in usable:
            motion = B.bailando_motion_beats(p, clip.fps, self.smooth)
            if len(motion) == 0:
                notes.append(_no_beat_note("BAS_bailando", clip))
            per_clip[clip.name] = {"BAS_bailando": B.bailando_score(music, motion, self.sigma)}
        value = float(np.mean([v["BAS_bailando"] for v in per_clip.values()]))
        return MetricResult({"BAS_bailando": value}, per_clip, notes)


class FactBAS:
    """FACT's beat alignment score: mean over motion beats of the Gaussian distance to a music beat."""

    needs = ("music",)

    def __init__(self, order_seconds: float = 10 / 60, sigma_seconds: float = 3 / 60):
        self.order, self.sigma = order_seconds, sigma_seconds

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Mean over clips of the per-clip score (0 for a clip without motion beats)."""
        usable, notes = with_music(generated, "BAS_fact")
        per_clip = {}
        for clip, p, music in usable:
            motion = B.fact_motion_beats(p, clip.fps, self.order)
            if len(motion) == 0:
                notes.append(_no_beat_note("BAS_fact", clip))
            per_clip[clip.name] = {"BAS_fact": B.fact_score(music, motion, self.sigma)}
        value = float(np.mean([v["BAS_fact"] for v in per_clip.values()]))
        return MetricResult({"BAS_fact": value}, per_clip, notes)


class Freezing:
    """TM2D's PFF and AUC_f (absolute threshold), and PFF_rel (threshold relative to the reference's speed).

    PFF: % of frames (pooled over the set) in runs of at least ``min_seconds`` whose largest joint
    speed is at most ``threshold`` m/s; AUC_f: mean PFF over thresholds 0 .. ``auc_max``. PFF_rel:
    the same with the threshold ``relative`` times the reference set's median per-frame largest
    joint speed (``PFF_rel_threshold``, m/s), reported only with a reference set.
    """

    needs: tuple[str, ...] = ()

    def __init__(
        self,
        threshold: float = 0.015,
        min_seconds: float = 3.0,
        auc_max: float = 0.03,
        auc_steps: int = 31,
        relative: float = 0.1,
    ):
        self.threshold, self.min_seconds, self.relative = threshold, min_seconds, relative
        self.thresholds = np.linspace(0.0, auc_max, auc_steps)

    def relative_threshold(self, reference: Sequence[JointClip]) -> float:
        """``relative`` times the median over every reference frame of its largest joint speed (m/s)."""
        speeds = [max_joint_speed(p, c.fps) for c in reference if len(p := check_positions(c)) >= 2]
        if not speeds:
            raise DataError("PFF_rel: every reference clip has fewer than 2 frames")
        return self.relative * float(np.median(np.concatenate(speeds)))

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Frame-weighted PFF, AUC_f (and PFF_rel) over clips at least ``min_seconds`` long."""
        require_clips(generated, 1, "PFF")
        per_clip, notes, frames, curves = {}, [], 0, []
        at = {"PFF": self.threshold}
        if reference:
            at["PFF_rel"] = self.relative_threshold(reference)
        else:
            notes.append("PFF_rel: no reference set (its threshold is relative to the reference's speed); not computed")
        frozen = dict.fromkeys(at, 0.0)
        for clip in generated:
            p = check_positions(clip)
            if len(p) < 2 or clip.duration < self.min_seconds:
                notes.append(
                    f"PFF: {clip.name}: {clip.duration:.2f} s is shorter than the "
                    f"{self.min_seconds:g} s a freeze must last; skipped"
                )
                continue
            speed = max_joint_speed(p, clip.fps)
            curve = pff_curve(speed, clip.fps, self.thresholds, self.min_seconds)
            pff = pff_curve(speed, clip.fps, np.array(list(at.values())), self.min_seconds)
            per_clip[clip.name] = {"AUC_f": auc(self.thresholds, curve)}
            for key, value in zip(at, pff, strict=True):
                per_clip[clip.name][key] = float(value)
                frozen[key] += value / 100.0 * len(p)
            frames += len(p)
            curves.append(curve * len(p))
        if not per_clip:
            names = ", ".join(c.name for c in generated)
            raise DataError(f"PFF: every clip is shorter than the {self.min_seconds:g} s a freeze must last ({names})")
        pooled = np.sum(curves, axis=0) / frames
        values = {"PFF": 100.0 * frozen["PFF"] / frames, "AUC_f": auc(self.thresholds, pooled)}
        if "PFF_rel" in at:
            values.update(PFF_rel=100.0 * frozen["PFF_rel"] / frames, PFF_rel_threshold=at["PFF_rel"])
        return MetricResult(values, per_clip, notes)


def pose_windows(
    clips: Sequence[JointClip],
    span: int,
    what: str,
    *,
    heading_free: bool = True,
    hips: list[str] | None = None,
    root_relative: bool = True,
) -> tuple[list[np.ndarray], list[str]]:
    """Per clip, its windows of ``span`` consecutive poses flattened to ``(T - span + 1, 3 J span)``; notes.

    ``heading_free``: each window in the body frame of its middle frame
    (:func:`dance_core.evaluation.canon.canonical_windows`: root over the origin, hips facing +Z),
    so a dance gives the same windows wherever and whichever way it is danced. When a clip's hips
    cannot be found (and no ``hips`` are named) every clip falls back, with a note, to the
    world-oriented windows: the frames as they are, with the root's horizontal position removed
    from each frame when ``root_relative``.
    """
    for clip in clips:
        require_frames(clip, span, what)
    notes: list[str] = []
    sides = None
    if heading_free:
        try:
            sides = [hip_indices(clip, hips) for clip in clips]
        except DataError as exc:
            if hips is not None:
                raise
            notes.append(f"{what}: {exc}; poses compared in world orientation, not heading-free")
    rows = []
    for i, clip in enumerate(clips):
        p = check_positions(clip)
        if sides is not None:
            w = canonical_windows(p, span, *sides[i])
        else:
            if root_relative:
                p = p.copy()
                p[..., [0, 2]] -= p[:, :1, [0, 2]]
            w = sliding_windows(p, span)
        rows.append(w.reshape(len(w), -1))
    return rows, notes


class FrechetPose:
    """Transflower's FPD (single poses) and FMD (three consecutive poses): Fréchet distances of pose windows.

    By default every window is in its own body frame (:func:`pose_windows`), so neither where nor
    which way a dancer faces counts; ``compat=True`` compares world-oriented frames with only the
    root's horizontal position removed (``root_relative``), this metric's earlier definition.
    """

    needs = ("reference",)

    def __init__(self, span: int, root_relative: bool = True, compat: bool = False, hips: list[str] | None = None):
        self.span, self.root_relative, self.compat, self.hips = span, root_relative, compat, hips
        self.value = "FPD" if span == 1 else "FMD"

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Windows pooled over each set (no normalization, as in the paper)."""
        require_clips(generated, 1, self.value)
        require_clips(reference, 1, self.value, "reference")
        same_joint_count(generated, reference, self.value)
        rates = {c.fps for c in [*generated, *reference]}
        if len(rates) > 1:
            raise DataError(f"{self.value}: clips at different frame rates {sorted(rates)}; resample to one fps")
        rows, notes = pose_windows(
            [*generated, *reference],
            self.span,
            self.value,
            heading_free=not self.compat,
            hips=self.hips,
            root_relative=self.root_relative,
        )
        gen, ref = np.concatenate(rows[: len(generated)]), np.concatenate(rows[len(generated) :])
        return MetricResult({self.value: set_distance(gen, ref, self.value)}, notes=notes)


def hips_index(clip: JointClip, hips: str | None) -> int:
    """Index of the hips joint: a named joint, else the root (joint 0)."""
    if hips is None:
        return 0
    if clip.joints is None or hips not in clip.joints:
        raise DataError(f"{clip.name}: beat offsets: no joint named {hips!r}")
    return list(clip.joints).index(hips)


class BeatOffset:
    """Transflower's beat offsets: mean and SD (s) of the time from each music beat to a hips beat."""

    needs = ("music",)

    def __init__(self, hips: str | None = None, smooth_seconds: float = 0.0):
        self.hips, self.smooth = hips, smooth_seconds

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Offsets pooled over every music beat of every clip with kinematic beats."""
        usable, notes = with_music(generated, "beat offset")
        pooled, per_clip = [], {}
        for clip, p, music in usable:
            kin = B.hips_beats(p, clip.fps, hips_index(clip, self.hips), self.smooth)
            if len(kin) == 0:
                notes.append(f"beat offset: {clip.name}: no kinematic beat (constant motion?); skipped")
                continue
            d = B.nearest_distances(music, kin)
            pooled.append(d)
            per_clip[clip.name] = {"beat_offset_mean": float(d.mean()), "beat_offset_sd": float(d.std())}
        if not pooled:
            reasons = "; ".join(n.removeprefix("beat offset: ") for n in notes)
            raise DataError(f"beat offset: no clip has kinematic beats ({reasons})")
        d = np.concatenate(pooled)
        return MetricResult({"beat_offset_mean": float(d.mean()), "beat_offset_sd": float(d.std())}, per_clip, notes)


class BeatLocking:
    """Phase locking of kinematic beats to the music beats, whatever the phase (mean over clips).

    Per clip :func:`dance_core.evaluation.quality.beat_locking`: the length of the circular mean of
    where the kinematic beats fall inside their music beat interval (1: always the same phase, on
    the beat or not; about ``1 / sqrt(n)`` for ``n`` beats at random), the better of two detectors
    (joint-speed minima, hips-height minima), and the same against a grid ``control_tempo`` times
    faster (a dance locked to the music scores low there).
    """

    needs = ("music",)

    def __init__(self, hips: str | None = None, control_tempo: float = CONTROL_TEMPO):
        self.hips, self.control_tempo = hips, control_tempo

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """``beat_locking`` and ``beat_locking_control``: means over clips with kinematic beats between music beats."""
        usable, notes = with_music(generated, "beat locking")
        per_clip = {}
        for clip, p, music in usable:
            s = beat_locking(p, clip.fps, music, hips_index(clip, self.hips), self.control_tempo)
            if not np.isfinite(s["locking"]):
                notes.append(f"beat locking: {clip.name}: no kinematic beat between two music beats; skipped")
                continue
            per_clip[clip.name] = {
                "beat_locking": s["locking"],
                "beat_locking_control": s["control"],
                "beat_locking_speed": s["locking_speed"],
                "beat_locking_hips": s["locking_hips"],
            }
        if not per_clip:
            reasons = "; ".join(n.removeprefix("beat locking: ") for n in notes)
            raise DataError(f"beat locking: no clip has kinematic beats between music beats ({reasons})")
        values = {
            k: float(np.nanmean([v[k] for v in per_clip.values()])) for k in ("beat_locking", "beat_locking_control")
        }
        return MetricResult(values, per_clip, notes)


class BeatCoverage:
    """DanceRevolution's beat coverage and hit rate (%), totals pooled over the set."""

    needs = ("music",)

    def __init__(self, tolerance_seconds: float = 0.1, smooth_seconds: float = 5 / 60):
        self.tolerance, self.smooth = tolerance_seconds, smooth_seconds

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """``100 * sum B_k / sum B_m`` and ``100 * sum B_a / sum B_k``."""
        usable, notes = with_music(generated, "beat coverage")
        bm = bk = ba = 0
        per_clip = {}
        for clip, p, music in usable:
            kin = B.bailando_motion_beats(p, clip.fps, self.smooth)
            coverage, hit = B.coverage_and_hit_rate(music, kin, self.tolerance)
            bm, bk, ba = bm + len(music), bk + len(kin), ba + int(round(hit * len(kin)))
            per_clip[clip.name] = {"beat_coverage": 100 * coverage, "beat_hit_rate": 100 * hit}
            if len(kin) == 0:
                notes.append(f"beat coverage: {clip.name}: no kinematic beat (constant motion?)")
        values = {"beat_coverage": 100.0 * bk / bm, "beat_hit_rate": 100.0 * ba / bk if bk else 0.0}
        return MetricResult(values, per_clip, notes)


class PhysicalFootContact:
    """EDGE's PFC (x 10,000; lower is better)."""

    needs: tuple[str, ...] = ()

    def __init__(self, feet: list[str] | None = None):
        self.feet = feet

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Mean over clips; clips whose root never accelerates score 0 (with a note)."""
        require_clips(generated, 1, "PFC")
        per_clip, notes = {}, []
        for clip in generated:
            p = require_frames(clip, 3, "PFC")
            score = pfc_clip(p, clip.fps, foot_indices(clip, self.feet))
            if score is None:
                notes.append(f"PFC: {clip.name}: the root never accelerates (constant motion); scored 0")
                score = 0.0
            per_clip[clip.name] = {"PFC": SCALE * score}
        return MetricResult({"PFC": float(np.mean([v["PFC"] for v in per_clip.values()]))}, per_clip, notes)


def build_fid_k(config: Any, **_: Any) -> FeatureFID:
    """``fid-k``."""
    return FeatureFID("kinetic", config.compat)


def build_fid_g(config: Any, **_: Any) -> FeatureFID:
    """``fid-g``."""
    return FeatureFID("geometric", config.compat)


def build_div_k(config: Any, **_: Any) -> FeatureDiversity:
    """``div-k``."""
    return FeatureDiversity("kinetic", config.compat)


def build_div_g(config: Any, **_: Any) -> FeatureDiversity:
    """``div-g``."""
    return FeatureDiversity("geometric", config.compat)


def build_bas_bailando(config: Any, **_: Any) -> BailandoBAS:
    """``bas-bailando``."""
    return BailandoBAS(config.smooth_seconds, config.sigma_seconds)


def build_bas_fact(config: Any, **_: Any) -> FactBAS:
    """``bas-fact``."""
    return FactBAS(config.order_seconds, config.sigma_seconds)


def build_freezing(config: Any, **_: Any) -> Freezing:
    """``freezing``."""
    return Freezing(config.threshold, config.min_seconds, config.auc_max, config.auc_steps, config.relative)


def build_fpd(config: Any, **_: Any) -> FrechetPose:
    """``fpd``."""
    return FrechetPose(1, config.root_relative, config.compat, config.hips)


def build_fmd(config: Any, **_: Any) -> FrechetPose:
    """``fmd``."""
    return FrechetPose(3, config.root_relative, config.compat, config.hips)


def build_beat_offset(config: Any, **_: Any) -> BeatOffset:
    """``beat-offset``."""
    return BeatOffset(config.hips, config.smooth_seconds)


def build_beat_locking(config: Any, **_: Any) -> BeatLocking:
    """``beat-locking``."""
    return BeatLocking(config.hips, config.control_tempo)


def build_beat_coverage(config: Any, **_: Any) -> BeatCoverage:
    """``beat-coverage``."""
    return BeatCoverage(config.tolerance_seconds, config.smooth_seconds)


def build_pfc(config: Any, **_: Any) -> PhysicalFootContact:
    """``pfc``."""
    return PhysicalFootContact(config.feet)
