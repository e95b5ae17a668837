"""The compiled Viterbi kernel of :mod:`.dbn`'s bar-pointer HMM (numba, cached on disk). Kept apart
from the model so that building a model, or decoding it another way (:mod:`.flux_beats`), does not
import numba."""

from __future__ import annotations

import numpy as np

from .numba_cache import use_cache_dir

use_cache_dir()  # before numba's first import, so the compiled kernel lands in dance's cache

import numba  # noqa: E402


@numba.njit(cache=True, nogil=True)
def viterbi(
    emit, periods, starts, on_beat, log_trans, dest_lo, dest_hi, log_init, beat_range, downbeat_range
):  # pragma: no cover - compiled
    """Most probable path of one bar HMM given ``(N, 3)`` log emissions (no NaN, no ``+inf``).

    Returns its log probability and, per frame, the beat index and whether the state is in the
    beat range (empty arrays if no path has a finite probability). Indices are unsigned where
    that lets LLVM vectorise (no negative-index wraparound).
    """
    frames = emit.shape[0]
    beats, n = on_beat.shape
    per_beat = 0
    for i in range(n):
        per_beat += periods[i]
    total = beats * per_beat
    score = np.full(total, log_init)
    # the scores of every beat's last states, kept per frame: back pointers are recomputed from
    # them for the few beat boundaries on the decoded path instead of stored for every state
    sources = np.empty((frames, beats, n))
    held = np.empty(beat_range.shape[0])
    best = np.empty(n)
    one, top = np.uint64(1), np.uint64(total - 1)
    for t in range(frames):
        e_none, e_beat, e_down = emit[t, 0], emit[t, 1], emit[t, 2]
        for b in range(beats):
            src_base = ((b - 1) % beats) * per_beat
            for j in range(n):
                sources[t, b, j] = score[src_base + starts[j] + periods[j] - 1]
        for q in range(beat_range.shape[0]):
            held[q] = score[beat_range[q] - one]
        for q in range(np.uint64(0), top):  # every chain advances one state, in place, from the end
            s = top - q
            score[s] = score[s - one] + e_none
        for b in range(beats):
            e_on = e_down if b == 0 else e_beat
            src = sources[t, b]
            for i in range(n):
                best[i] = -np.inf
            for j in range(n):  # banded max-plus product into the first states of beat b
                from_score = src[j]
                row = log_trans[j]
                for i in range(np.uint64(dest_lo[j]), np.uint64(dest_hi[j])):
                    v = (from_score + row[i]) + e_on
                    old = best[i]
                    best[i] = v if v > old else old
            base = b * per_beat
            for i in range(n):
                score[base + starts[i]] = best[i]
        for q in range(downbeat_range):  # the beat-range states emit a (down)beat, not a non-beat
            score[beat_range[q]] = held[q] + e_down
        for q in range(downbeat_range, beat_range.shape[0]):
            score[beat_range[q]] = held[q] + e_beat
    state = 0
    for s in range(total):
        if score[s] > score[state]:
            state = s
    log_prob = score[state]
    if frames == 0 or not log_prob > -np.inf:
        return log_prob, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.bool_)
    b = state // per_beat
    offset = state - b * per_beat
    i = n - 1
    while starts[i] > offset:
        i -= 1
    offset -= starts[i]
    path_beat = np.empty(frames, dtype=np.int64)
    path_on = np.empty(frames, dtype=np.bool_)
    for t in range(frames - 1, -1, -1):
        path_beat[t] = b
        path_on[t] = offset < on_beat[b, i]
        if offset > 0:
            offset -= 1
            continue
        e_on = emit[t, 2] if b == 0 else emit[t, 1]
        best_v, best_j = -np.inf, 0
        for j in range(n):  # the first most probable predecessor, as the forward pass compared them
            v = (sources[t, b, j] + log_trans[j, i]) + e_on
            if v > best_v:
                best_v, best_j = v, j
        b = (b - 1) % beats
        i = best_j
        offset = periods[i] - 1
    return log_prob, path_beat, path_on
