"""Onset strength, tempogram, tempo and dynamic-programming beat tracking over an onset envelope.

The same computations as librosa's ``onset.onset_strength`` (on a dB mel spectrogram),
``feature.tempogram``, ``feature.tempo`` and ``beat.beat_track`` (Ellis 2007), in numpy: the
beat tracker's dynamic program runs in blocks of frames whose predecessors are all known, so it
needs no compiled loop. Envelopes are 1-D over frames; ``frame_rate`` is frames per second.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.fft

from .stft import periodic_hann


def spectral_flux(db: np.ndarray, aggregate: Callable[..., np.ndarray] = np.mean, delay: int = 1) -> np.ndarray:
    """Spectral flux of a ``(n_frames, n_bands)`` dB spectrogram, aggregated over bands, float32.

    ``aggregate(max(0, db[t] - db[t-1]), axis=1)`` placed at frame ``t - 1 + delay`` (zeros before),
    cut to ``n_frames``; ``delay=1`` puts each rise at the frame where it ends.
    """
    flux = np.maximum(0.0, db[1:] - db[:-1])
    env = aggregate(flux, axis=1) if len(flux) else np.zeros(0, dtype=db.dtype)
    return np.concatenate([np.zeros(delay, dtype=env.dtype), env])[: len(db)].astype(np.float32)


def onset_strength(
    db: np.ndarray, n_fft: int, hop: int, aggregate: Callable[..., np.ndarray] = np.median
) -> np.ndarray:
    """librosa's ``onset_strength(S=db, lag=1, max_size=1, center=True)``: the spectral flux delayed by
    ``1 + n_fft // (2 hop)`` frames (the lag, and the centred frames' look-ahead)."""
    return spectral_flux(db, aggregate, 1 + n_fft // (2 * hop))


def _padded_frames(onset_envelope: np.ndarray, win_length: int, dtype: type) -> np.ndarray:
    """``(n_frames, n_fft)`` Hann-windowed stretches of ``win_length`` frames centred on each frame
    (the envelope ramps linearly to 0 beyond its ends), zero padded to an FFT size that makes
    their circular autocorrelation linear up to lag ``win_length - 1``."""
    env = np.asarray(onset_envelope)
    half = win_length // 2
    padded = np.pad(env, (half, half), mode="linear_ramp", end_values=(0, 0))
    n_fft = scipy.fft.next_fast_len(2 * win_length - 1, real=True)
    frames = np.zeros((len(env), n_fft), dtype=dtype)
    windows = np.lib.stride_tricks.sliding_window_view(padded, win_length)[: len(env)]
    np.multiply(windows, periodic_hann(win_length, np.float64).astype(dtype), out=frames[:, :win_length])
    return frames


def tempogram(onset_envelope: np.ndarray, win_length: int = 384, dtype: type = np.float64) -> np.ndarray:
    """``(n_frames, win_length)`` local autocorrelation of the onset envelope.

    Frame t is the Hann-windowed stretch of ``win_length`` frames centred on t (the envelope ramps
    linearly to 0 beyond its ends), autocorrelated (lags ``0 .. win_length - 1``) and divided by
    its largest absolute value (frames without energy stay 0): librosa's ``tempogram``, bit for
    bit in float64; ``dtype=np.float32`` is twice as fast, within ~1e-6.
    """
    frames = _padded_frames(onset_envelope, win_length, dtype)
    n_fft = frames.shape[1]
    spectrum = scipy.fft.rfft(frames, axis=1, workers=-1)
    power = spectrum.real**2
    power += spectrum.imag**2
    spectrum.real, spectrum.imag = power, 0.0  # a complex input spares irfft a conversion
    autocorr = scipy.fft.irfft(spectrum, n=n_fft, axis=1, workers=-1)[:, :win_length]
    peak = np.abs(autocorr).max(axis=1, keepdims=True)
    peak[peak < np.finfo(dtype).tiny] = 1.0
    return autocorr / peak


def mean_tempogram(onset_envelope: np.ndarray, win_length: int) -> np.ndarray:
    """The time average of :func:`tempogram` (float64), with one inverse FFT: each frame's
    autocorrelation peaks at lag 0 (its energy), and the inverse FFT is linear, so the average of
    the normalised autocorrelations is the inverse FFT of the average energy-normalised spectrum."""
    frames = _padded_frames(onset_envelope, win_length, np.float64)
    energy = np.einsum("ij,ij->i", frames, frames)
    energy[energy < np.finfo(np.float64).tiny] = 1.0
    spectrum = scipy.fft.rfft(frames, axis=1, workers=-1)
    power = spectrum.real**2
    power += spectrum.imag**2
    power /= energy[:, None]
    return scipy.fft.irfft(power.mean(axis=0), n=frames.shape[1])[:win_length]


def tempo_bpms(win_length: int, frame_rate: float) -> np.ndarray:
    """Tempo (BPM) of each tempogram lag: ``60 frame_rate / lag``; lag 0 is infinite."""
    bpms = np.full(win_length, np.inf)
    bpms[1:] = 60.0 * frame_rate / np.arange(1.0, win_length)
    return bpms


def estimate_tempo(
    onset_envelope: np.ndarray,
    frame_rate: float,
    start_bpm: float = 120.0,
    std_bpm: float = 1.0,
    ac_size: float = 8.0,
    max_tempo: float = 320.0,
) -> float:
    """The global tempo (BPM): the peak of the time-averaged ``ac_size``-second tempogram, weighted
    by a log-normal prior around ``start_bpm`` (``std_bpm`` octaves wide), below ``max_tempo``.
    librosa's ``feature.tempo`` with ``aggregate=np.mean``."""
    win_length = int(np.floor(ac_size * frame_rate + 1e-9))
    strength = mean_tempogram(onset_envelope, win_length)
    bpms = tempo_bpms(win_length, frame_rate)
    with np.errstate(divide="ignore"):
        log_prior = -0.5 * ((np.log2(bpms) - np.log2(start_bpm)) / std_bpm) ** 2
    log_prior[: int(np.argmax(bpms < max_tempo))] = -np.inf
    return float(bpms[np.argmax(np.log1p(1e6 * strength) + log_prior)])


def _local_score(onsets: np.ndarray, period: float) -> np.ndarray:
    """Onsets over their standard deviation, smoothed by a Gaussian of ``period / 32`` frames' width
    spanning one period either side. As in librosa, frame 0 does not contribute."""
    onsets = onsets / (onsets.std(ddof=1) + np.finfo(onsets.dtype).tiny)
    span = int(period)
    window = np.exp(-0.5 * (np.arange(-span, span + 1) * 32.0 / period) ** 2)
    source = onsets.astype(np.float64)
    source[0] = 0.0
    return np.convolve(source, window)[span : span + len(onsets)]


def _beat_dp(score: np.ndarray, period: float, tightness: float) -> tuple[np.ndarray, np.ndarray]:
    """Best-path scores and back-links: a beat at frame i follows one ``round(period / 2) .. 2 period``
    frames earlier, paying ``tightness * log(gap / period)**2`` (ties go to the latest); frames
    before the first whose score reaches 1 % of the maximum start no chain (back-link -1)."""
    n = len(score)
    nearest = max(1, int(np.round(period / 2)))  # a gap of 0 would score -inf: never chosen
    gaps = np.arange(nearest, int(2 * period) + 1)
    penalty = tightness * (np.log(gaps) - np.log(period)) ** 2
    cumulative = np.empty(n)
    backlink = np.full(n, -1, dtype=np.int64)
    # frames i0 .. i0 + nearest - 1 only look back to frames before i0: solve them together
    offsets = np.arange(nearest)[:, None] - gaps[None, :]
    rows = np.arange(nearest)
    for start in range(0, n, nearest):
        count = min(nearest, n - start)
        previous = start + offsets[:count]
        if start >= gaps[-1]:
            candidates = cumulative[previous] - penalty
        else:
            candidates = np.where(previous >= 0, cumulative[np.maximum(previous, 0)] - penalty, -np.inf)
        best = np.argmax(candidates, axis=1)
        chosen = previous[rows[:count], best]
        found = chosen >= 0
        cumulative[start : start + count] = score[start : start + count] + np.where(
            found, candidates[rows[:count], best], 0.0
        )
        backlink[start : start + count] = np.where(found, chosen, -1)
    started = np.flatnonzero(score >= 0.01 * score.max())
    backlink[: started[0] if len(started) else n] = -1
    return backlink, cumulative


def _last_beat(cumulative: np.ndarray) -> int:
    """The last local maximum of the cumulative score reaching half the median of such maxima."""
    peaks = np.zeros(len(cumulative), dtype=bool)
    peaks[1:-1] = (cumulative[1:-1] > cumulative[:-2]) & (cumulative[1:-1] >= cumulative[2:])
    peaks[-1] = cumulative[-1] > cumulative[-2]
    if not peaks.any():
        return len(cumulative) - 1
    good = np.flatnonzero(peaks & (cumulative >= 0.5 * np.median(cumulative[peaks])))
    return int(good[-1]) if len(good) else len(cumulative) - 1


def _trim(score: np.ndarray, beats: np.ndarray, trim: bool) -> np.ndarray:
    """Drop beats in the leading and trailing frames whose local score is at most half the RMS of
    the (Hann-smoothed) local score at the beats; without ``trim``, at most 0."""
    beats = beats.copy()
    threshold = 0.0
    if trim:
        smooth = np.convolve(score[beats], np.hanning(5))[2 : 2 + len(score)]  # (with its tail, as librosa)
        threshold = 0.5 * np.sqrt(np.mean(smooth**2))
    quiet = score <= threshold
    head = np.argmin(quiet) if not quiet.all() else len(score)
    beats[:head] = False
    tail = np.argmin(quiet[::-1]) if not quiet.all() else len(score)
    beats[len(score) - tail :] = False
    return beats


def beat_track(
    onset_envelope: np.ndarray,
    frame_rate: float,
    start_bpm: float = 120.0,
    tightness: float = 100.0,
    trim: bool = True,
    bpm: float | None = None,
) -> tuple[float, np.ndarray]:
    """``(tempo in BPM, beat frame indices)`` of an onset envelope sampled at ``frame_rate`` Hz.

    librosa's ``beat.beat_track(onset_envelope=..., sr=..., hop_length=...)`` with
    ``frame_rate = sr / hop_length``: the tempo (unless ``bpm`` is given) from
    :func:`estimate_tempo` with a prior around ``start_bpm``; beats by dynamic programming over the
    smoothed, normalised envelope; the chain traced back from the last strong cumulative peak;
    weak leading and trailing beats trimmed. An all-zero envelope gives ``(0.0, [])``.
    """
    env = np.asarray(onset_envelope)
    if env.ndim != 1:
        raise ValueError("beat_track: the onset envelope must be 1-D")
    if not np.issubdtype(env.dtype, np.floating):
        env = env.astype(np.float64)
    if len(env) < 2 or not env.any():
        return 0.0, np.zeros(0, dtype=np.int64)
    tempo = estimate_tempo(env, frame_rate, start_bpm) if bpm is None else float(bpm)
    if tempo <= 0:
        raise ValueError(f"beat_track: bpm={tempo} must be positive")
    period = max(1.0, float(np.round(frame_rate * 60.0 / tempo)))  # frames per beat
    score = _local_score(env, period)
    backlink, cumulative = _beat_dp(score, period, tightness)
    beats = np.zeros(len(env), dtype=bool)
    frame = _last_beat(cumulative)
    while frame >= 0:
        beats[frame] = True
        frame = backlink[frame]
    return tempo, np.flatnonzero(_trim(score, beats, trim))
