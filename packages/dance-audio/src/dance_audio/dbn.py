"""Beat and downbeat decoding with a bar-pointer HMM: the DBN downbeat tracker of Böck, Krebs and
Widmer (ISMIR 2016), written to decode exactly as madmom 0.16.1's ``DBNDownBeatTrackingProcessor``.

The model, one HMM per bar length ``B`` (beats per bar):

* **States.** A tempo is a beat period of ``L`` frames, one of about ``num_tempi`` integer periods
  between ``60 fps / max_bpm`` and ``60 fps / min_bpm`` (log spaced, rounded, duplicates dropped).
  A beat at period ``L`` is a chain of ``L`` states, one per frame of the beat; a bar is ``B`` such
  beats. State ``(b, L, k)`` is the ``k``-th frame of beat ``b`` at period ``L``: ``B * sum(L)``
  states in all, each with a bar position ``b + k / L``.
* **Transitions.** Inside a beat the chain advances one state per frame with probability 1. From
  the last state of beat ``b - 1`` (cyclically) the next frame enters the first state of beat
  ``b`` at any period ``L'``, with probability ``exp(-lambda |L' / L - 1|)`` normalised over
  ``L'`` (values at or below machine epsilon are 0): tempo changes only at beat boundaries, and
  small changes are far more likely than large ones.
* **Observations.** The network gives per frame a beat probability ``p_b`` and a downbeat
  probability ``p_d``. The first ``1 / observation_lambda`` of every beat (bar position modulo 1
  below that fraction) is the beat range: it emits ``p_d`` in beat 0 and ``p_b`` in the others; all
  other states emit ``(1 - p_b - p_d) / (observation_lambda - 1)``.
* **Decoding.** Activations are cropped to the frames from the first to the last one where either
  probability reaches ``threshold`` (as in madmom, if only frame 0 does, nothing is left). Each
  bar length's HMM is decoded with Viterbi from a uniform start; the most probable path wins.
  Every run of beat-range frames on it is one beat, placed on the frame of that run with the
  largest (beat or downbeat) activation (``correct``), or else on the frame where the beat
  counter changes.

The Viterbi kernel (:mod:`.dbn_kernel`, numba) exploits the sparse structure: a chain state's score is its predecessor's
plus the emission (all chains advance together, in place: one long vectorised add per frame,
then the few beat-range states get their beat emission instead), and only the first state of
each beat and period maximises over incoming tempo transitions (a banded, period by period,
max-plus product). No back pointers are stored: chain states step back one state, and at a beat
boundary the kernel keeps the last states' scores per frame and recomputes the winning
predecessor while tracing back. Scores are float64 sums formed in madmom's order
(``previous + log transition + log emission``; ties go to the lowest predecessor, as madmom's
strict ``>``), so the decoded paths are madmom's, bit for bit. Memory is one float per beat,
tempo and frame: about 12 MB per minute at 100 fps for a 4-beat bar with 60 tempi, where madmom
keeps a back pointer per state and frame (about 400 MB).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

NUM_TEMPI, TRANSITION_LAMBDA, OBSERVATION_LAMBDA, THRESHOLD = 60, 100.0, 16, 0.05


def tempo_periods(min_period: float, max_period: float, num_tempi: int | None) -> np.ndarray:
    """Integer beat periods (frames) modelled between ``min_period`` and ``max_period``.

    Every integer period in the rounded range, unless that is more than ``num_tempi``: then
    ``n >= num_tempi`` log-spaced periods, rounded and deduplicated, with the smallest such ``n``
    that keeps at least ``num_tempi`` distinct ones.
    """
    periods = np.arange(np.round(min_period), np.round(max_period) + 1)
    if num_tempi is not None and num_tempi < len(periods):
        n, periods = num_tempi, np.zeros(0)
        while len(periods) < num_tempi:
            spaced = np.logspace(np.log2(min_period), np.log2(max_period), n, base=2)
            periods = np.unique(np.round(spaced))
            n += 1
    return np.ascontiguousarray(periods, dtype=np.int64)


def tempo_log_transitions(periods: np.ndarray, transition_lambda: float) -> np.ndarray:
    """``(n, n)`` log probabilities of moving from period ``periods[j]`` (row) to ``periods[i]``
    (column) at a beat boundary; ``-inf`` where the probability is cut to 0."""
    ratio = periods.astype(np.float64) / periods.astype(np.float64)[:, np.newaxis]
    prob = np.exp(-transition_lambda * np.abs(ratio - 1.0))
    prob[prob <= np.spacing(1)] = 0.0
    prob /= np.sum(prob, axis=1)[:, np.newaxis]
    with np.errstate(divide="ignore"):
        return np.log(prob)


@dataclass(frozen=True)
class BarModel:
    """The HMM of one bar length: its periods, state layout and transition tables."""

    beats: int
    periods: np.ndarray  # (n,) beat periods in frames
    starts: np.ndarray  # (n,) offset of each period's chain inside one beat's block of states
    on_beat: np.ndarray  # (beats, n) how many leading states of each chain are in the beat range
    log_trans: np.ndarray  # (n, n) from period j (row) to period i (column)
    dest_lo: np.ndarray  # (n,) first destination period reachable from period j
    dest_hi: np.ndarray  # (n,) one past the last reachable destination period
    log_init: float  # log of the uniform initial probability
    beat_range: np.ndarray  # (m,) uint64 beat-range states past a chain's first (the downbeat's first)
    downbeat_range: int  # how many of ``beat_range`` lie in the bar's first beat

    def viterbi(self, emit: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Decode ``(N, 3)`` log emissions (:func:`log_emissions`): the path's log probability,
        then per frame its beat index and beat-range flag (empty if no path is possible)."""
        from .dbn_kernel import viterbi  # numba: imported when a model first decodes

        return viterbi(
            emit, self.periods, self.starts, self.on_beat, self.log_trans, self.dest_lo, self.dest_hi,
            self.log_init, self.beat_range, self.downbeat_range,
        )  # fmt: skip


@lru_cache(maxsize=32)
def bar_model(
    beats: int,
    min_period: float,
    max_period: float,
    num_tempi: int | None,
    transition_lambda: float,
    observation_lambda: float,
) -> BarModel:
    """Build (and cache) the :class:`BarModel` for ``beats`` beats per bar."""
    periods = tempo_periods(min_period, max_period, num_tempi)
    log_trans = tempo_log_transitions(periods, transition_lambda)
    reachable = np.isfinite(log_trans)
    dest_lo = np.argmax(reachable, axis=1)
    dest_hi = len(periods) - np.argmax(reachable[:, ::-1], axis=1)
    if not all(reachable[j, dest_lo[j] : dest_hi[j]].all() for j in range(len(periods))):
        raise AssertionError("tempo transitions are expected to form a band")
    border = 1.0 / observation_lambda
    on_beat = np.empty((beats, len(periods)), dtype=np.int64)
    for i, period in enumerate(periods):
        frac = np.linspace(0, 1, int(period), endpoint=False)
        for b in range(beats):
            inside = (frac + b) % 1 < border  # the bar positions as madmom forms them
            on_beat[b, i] = np.count_nonzero(inside)
            if not inside[: on_beat[b, i]].all() or on_beat[b, i] < 1:
                raise AssertionError("the beat range is expected to be a chain's first states")
    num_states = beats * int(periods.sum())
    log_init = float(np.log(np.ones(num_states) / num_states)[0])
    starts = np.concatenate(([0], np.cumsum(periods)[:-1])).astype(np.int64)
    per_beat = int(periods.sum())
    beat_range = [
        b * per_beat + starts[i] + k for b in range(beats) for i in range(len(periods)) for k in range(1, on_beat[b, i])
    ]
    return BarModel(
        beats,
        periods,
        starts,
        on_beat,
        log_trans,
        dest_lo.astype(np.int64),
        dest_hi.astype(np.int64),
        log_init,
        np.array(beat_range, dtype=np.uint64),
        int(np.sum(on_beat[0] - 1)),
    )


def log_emissions(activations: np.ndarray, observation_lambda: float) -> np.ndarray:
    """``(N, 3)`` float64 log emission probabilities: non-beat, beat, downbeat.

    Computed in the activations' own dtype, as madmom does. A NaN (a probability sum above 1, or
    a negative activation) becomes ``-inf``: madmom's strict ``>`` never picks a NaN score either.
    """
    out = np.empty((len(activations), 3), dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out[:, 0] = np.log((1.0 - np.sum(activations, axis=1)) / (observation_lambda - 1))
        out[:, 1] = np.log(activations[:, 0])
        out[:, 2] = np.log(activations[:, 1])
    out[np.isnan(out)] = -np.inf
    return out


def _per_bar(value, count: int, name: str) -> list:
    """``value`` repeated for each bar length, or a per-bar-length sequence checked for length."""
    values = list(value) if isinstance(value, (list, tuple, np.ndarray)) else [value]
    if len(values) == 1:
        values = values * count
    if len(values) != count:
        raise ValueError(f"{name} needs one value or one per bar length ({count})")
    return values


class DBNDownBeatTracker:
    """Beats and bar positions from beat/downbeat activations; decodes as madmom 0.16.1's
    ``DBNDownBeatTrackingProcessor`` with the same arguments (``min_bpm``, ``max_bpm``,
    ``num_tempi`` and ``transition_lambda`` may be one value or one per bar length)."""

    def __init__(
        self,
        beats_per_bar,
        min_bpm=55.0,
        max_bpm=215.0,
        num_tempi=NUM_TEMPI,
        transition_lambda=TRANSITION_LAMBDA,
        observation_lambda=OBSERVATION_LAMBDA,
        threshold=THRESHOLD,
        correct: bool = True,
        fps: float = 100.0,
    ):
        bars = [int(b) for b in np.atleast_1d(beats_per_bar)]
        if not bars or min(bars) < 1:
            raise ValueError("beats_per_bar needs at least one positive bar length")
        if not observation_lambda > 1:
            raise ValueError("observation_lambda must be above 1")
        lows = _per_bar(min_bpm, len(bars), "min_bpm")
        highs = _per_bar(max_bpm, len(bars), "max_bpm")
        tempi = _per_bar(num_tempi, len(bars), "num_tempi")
        lambdas = _per_bar(transition_lambda, len(bars), "transition_lambda")
        self.beats_per_bar, self.fps = bars, float(fps)
        self.threshold, self.correct = threshold, bool(correct)
        self.observation_lambda = observation_lambda
        self.models = [
            bar_model(
                bars[k],
                60.0 * self.fps / float(highs[k]),
                60.0 * self.fps / float(lows[k]),
                None if tempi[k] is None else int(tempi[k]),
                float(lambdas[k]),
                float(observation_lambda),
            )
            for k in range(len(bars))
        ]

    def decode(self, activations: np.ndarray) -> tuple[int, list[float], np.ndarray, np.ndarray]:
        """Viterbi over every bar length's HMM: the winner's index, every HMM's path log
        probability, then per frame of the winning path its beat index (0 = downbeat) and
        beat-range flag (empty arrays if no path has a finite probability)."""
        emit = log_emissions(activations, self.observation_lambda)
        with ThreadPoolExecutor(min(len(self.models), os.cpu_count() or 1)) as pool:  # the kernel is nogil
            results = list(pool.map(lambda model: model.viterbi(emit), self.models))
        log_probs = [float(r[0]) for r in results]
        winner = int(np.argmax(log_probs))
        return winner, log_probs, results[winner][1], results[winner][2]

    def __call__(self, activations: np.ndarray) -> np.ndarray:
        """``(num_beats, 2)``: beat times in seconds and bar positions (1 = downbeat), from
        ``(N, 2)`` beat and downbeat activations at ``fps``."""
        act = np.asarray(activations)
        if act.ndim != 2 or act.shape[1] != 2:
            raise ValueError(f"activations must be (frames, 2), got {act.shape}")
        if not np.all(np.isfinite(act)):
            raise ValueError("activations must be finite")
        first = 0
        if self.threshold:
            rows = np.nonzero(act >= self.threshold)[0]
            # madmom's crop: a hit only on frame 0 counts as no hit (it tests the indices' truth)
            last = int(rows.max()) + 1 if rows.any() else 0
            first = int(rows.min()) if rows.any() else 0
            act = act[first:last]
        if not act.any():
            return np.empty((0, 2))
        _, _, beat_index, on_beat = self.decode(act)
        if len(beat_index) == 0:  # no finite-probability path (madmom raises an IndexError here)
            return np.empty((0, 2))
        if self.correct:
            edges = np.flatnonzero(np.diff(on_beat.astype(np.int8))) + 1
            if on_beat[0]:
                edges = np.r_[0, edges]
            if on_beat[-1]:
                edges = np.r_[edges, len(on_beat)]
            frames = np.array(
                [lo + np.argmax(act[lo:hi]) // act.shape[1] for lo, hi in edges.reshape(-1, 2)], dtype=np.int64
            )
        else:
            frames = np.flatnonzero(np.diff(beat_index)) + 1
        return np.stack(((frames + first) / self.fps, beat_index[frames] + 1.0), axis=1).reshape(-1, 2)
