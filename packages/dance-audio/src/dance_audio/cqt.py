"""Constant-Q transform and chromagram, as ``librosa.cqt`` and ``librosa.feature.chroma_cqt``.

The transform runs octave by octave from the top (Schoerkhuber & Klapuri's multirate scheme): one
octave's filters (Hann-windowed complex exponentials of ``Q`` cycles, L1 normalised, taken to the
frequency domain and sparsified) are applied to a centred box-window STFT of the signal; the
signal is then halved in rate with soxr's HQ filter, and so is the hop, for the octave below. The
signal may first be decimated when the top filter and the hop allow it (librosa's early
downsampling). Magnitudes are scaled by ``1 / sqrt(filter length)``.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.fft

from .stft import stft

C1 = 440.0 * 2.0 ** ((24 - 69) / 12.0)  # Hz, MIDI note 24: librosa's default lowest bin
HANN_BANDWIDTH = 1.50018310546875  # a Hann window's bandwidth in bins, as librosa tabulates it
SPARSITY = 0.01  # share of each filter's L1 mass dropped with its smallest frequency bins


def cqt_frequencies(n_bins: int, fmin: float, bins_per_octave: int) -> np.ndarray:
    """Centre frequencies ``fmin * 2**(k / bins_per_octave)``, as librosa builds them (octave by octave)."""
    ratios = 2.0 ** (np.arange(bins_per_octave, dtype=float) / bins_per_octave)
    n_octaves = int(np.ceil(n_bins / bins_per_octave))
    return np.multiply.outer(2.0 ** np.arange(n_octaves), ratios).ravel()[:n_bins] * fmin


def relative_bandwidths(freqs: np.ndarray) -> np.ndarray:
    """Each filter's bandwidth over its frequency, from the local spacing of ``freqs`` (log2)."""
    logf = np.log2(freqs)
    bpo = np.empty_like(freqs)
    bpo[0] = 1 / (logf[1] - logf[0])
    bpo[-1] = 1 / (logf[-1] - logf[-2])
    bpo[1:-1] = 2 / (logf[2:] - logf[:-2])
    return (2.0 ** (2 / bpo) - 1) / (2.0 ** (2 / bpo) + 1)


def filter_lengths(freqs: np.ndarray, rate: float, alpha: np.ndarray) -> tuple[np.ndarray, float]:
    """Filter lengths in samples (``Q * rate / f``, ``Q = 1 / alpha``) and the highest frequency reached."""
    q = 1.0 / alpha
    cutoff = float(np.max(freqs * (1 + 0.5 * HANN_BANDWIDTH / q)))
    return q * rate / freqs, cutoff


def _octave_filters(freqs: np.ndarray, rate: float, alpha: np.ndarray, gain: float) -> tuple[np.ndarray, int, int]:
    """One octave's filters in the frequency domain: ``(n_filters, n_used)`` complex64 over FFT bins
    ``first .. first + n_used`` of an ``n_fft``-point FFT; returns ``(basis, n_fft, first)``.

    Each filter is a Hann-windowed complex exponential of ``ceil(length)`` samples, L1 normalised,
    centred in ``n_fft`` (the next power of two), scaled by ``length / n_fft``; the smallest bins
    of its spectrum holding 1 % of its L1 mass are zeroed (librosa's ``sparsify_rows``), and the
    rest multiplied by ``gain``.
    """
    lengths, _ = filter_lengths(freqs, rate, alpha)
    n_fft = int(2.0 ** np.ceil(np.log2(lengths.max())))
    first_t = -lengths // 2  # filter k spans t = first_t[k] + j, j < size[k] (= ceil(length))
    size = (lengths // 2 - first_t).astype(np.int64)
    j = np.arange(size.max())
    inside = j[None, :] < size[:, None]
    angle = (first_t[:, None] + j[None, :]) * 2 * np.pi * freqs[:, None] / rate
    hann = 0.5 + 0.5 * np.cos(j[None, :] * (2 * np.pi / size[:, None]) + -np.pi)  # scipy's, per size
    sig = np.where(inside, (np.cos(angle) + 1j * np.sin(angle)) * hann, 0)
    sig /= np.sum(np.abs(sig), axis=1, keepdims=True)
    time = np.zeros((len(freqs), n_fft), dtype=np.complex64)
    rows = np.broadcast_to(np.arange(len(freqs))[:, None], inside.shape)
    cols = (n_fft - size[:, None]) // 2 + j[None, :]
    time[rows[inside], cols[inside]] = sig[inside]
    time *= lengths[:, None] / float(n_fft)
    spectra = scipy.fft.fft(time, n=n_fft, axis=1)[:, : n_fft // 2 + 1]
    mags = np.abs(spectra)
    ordered = np.sort(mags, axis=1)
    mass = np.cumsum(ordered / np.sum(mags, axis=1, keepdims=True), axis=1)
    cut = ordered[np.arange(len(freqs)), np.argmin(mass < SPARSITY, axis=1)]
    spectra[mags < cut[:, None]] = 0
    used = np.flatnonzero(np.any(spectra != 0, axis=0))
    first, last = int(used[0]), int(used[-1]) + 1
    basis = (spectra[:, first:last] * np.float64(gain)).astype(np.complex64)
    return basis, n_fft, first


def _halvings(hop: int) -> int:
    """How many times ``hop`` can be halved (its factors of two)."""
    twos = 0
    while hop > 0 and hop % 2 == 0:
        twos, hop = twos + 1, hop // 2
    return twos


@lru_cache(maxsize=8)
def _filter_bank(rate: float, fmin: float, n_bins: int, bins_per_octave: int, halvings: int) -> tuple:
    """Per octave (top first): its bins, filters, FFT size and first FFT bin. Octave ``i`` runs at
    ``rate / 2**min(i, halvings)`` (the signal is halved with the hop while the hop is even)."""
    freqs = cqt_frequencies(n_bins, fmin, bins_per_octave)
    alpha = relative_bandwidths(freqs)
    octaves = []
    for i in range(int(np.ceil(n_bins / bins_per_octave))):
        hi = n_bins - bins_per_octave * i
        lo = max(hi - bins_per_octave, 0)
        factor = 2.0 ** min(i, halvings)
        basis, n_fft, first = _octave_filters(freqs[lo:hi], rate / factor, alpha[lo:hi], np.sqrt(factor))
        octaves.append((lo, hi, basis, n_fft, first))
    return tuple(octaves)


def _early_downsampling(rate: float, cutoff: float, hop: int, n_octaves: int) -> int:
    """How many times the signal can be halved before the first octave (librosa's rule)."""
    by_band = max(0, int(np.ceil(np.log2(rate / 2.0 / cutoff)) - 1) - 1)
    return min(by_band, max(0, _halvings(hop) - n_octaves + 1))


def _decimate(y: np.ndarray, factor: int) -> np.ndarray:
    """Decimate by ``factor`` with soxr's HQ filter, keeping ``ceil(len / factor)`` samples and the
    energy per filter (a ``sqrt(factor)`` gain), as ``librosa.resample(..., scale=True)``."""
    import soxr

    out = soxr.resample(y, factor, 1, quality="soxr_hq")
    n = -(-len(y) // factor)
    out = out[:n] if len(out) >= n else np.pad(out, (0, n - len(out)))
    return (out / np.sqrt(1.0 / factor)).astype(np.float32)


def cqt_magnitude(
    y: np.ndarray, rate: float, hop: int, fmin: float = C1, n_bins: int = 84, bins_per_octave: int = 12
) -> np.ndarray:
    """``(n_frames, n_bins)`` float32 constant-Q magnitudes, frames centred at ``t * hop``.

    ``fmin`` already includes any tuning. The frame count is the smallest over the octaves.
    """
    n_octaves = int(np.ceil(n_bins / bins_per_octave))
    freqs = cqt_frequencies(n_bins, fmin, bins_per_octave)
    alpha = relative_bandwidths(freqs)
    _, cutoff = filter_lengths(freqs[-bins_per_octave:], rate, alpha[-bins_per_octave:])
    if cutoff > rate / 2.0:
        raise ValueError(f"constant-Q filters up to {cutoff:.0f} Hz exceed the Nyquist frequency {rate / 2:.0f} Hz")
    y = np.asarray(y, dtype=np.float32)
    early = _early_downsampling(rate, cutoff, hop, n_octaves)
    if early > 0:
        y, rate, hop = _decimate(y, 2**early), rate / 2**early, hop // 2**early
    octaves = _filter_bank(float(rate), float(fmin), n_bins, bins_per_octave, _halvings(hop))
    responses = []
    for i, (lo, hi, basis, n_fft, first) in enumerate(octaves):
        spec = stft(y, n_fft, hop, window="box")[:, first : first + basis.shape[1]]
        responses.append((lo, hi, np.abs(spec @ basis.T)))
        if i + 1 < len(octaves) and hop % 2 == 0:
            y, hop = _decimate(y, 2), hop // 2
    n_frames = min(len(r) for _, _, r in responses)
    lengths, _ = filter_lengths(freqs, rate, alpha)
    out = np.empty((n_frames, n_bins), dtype=np.float32)
    for lo, hi, response in responses:
        out[:, lo:hi] = response[:n_frames]
    out /= np.sqrt(lengths).astype(np.float32)
    return out


def chroma_map(n_bins: int, bins_per_octave: int = 36, n_chroma: int = 12) -> np.ndarray:
    """``(n_chroma, n_bins)`` 0/1 float32 matrix folding constant-Q bins from C1 onto pitch classes
    (C first), each class gathering the ``bins_per_octave / n_chroma`` bins centred on it per octave."""
    merge = bins_per_octave // n_chroma
    if merge * n_chroma != bins_per_octave:
        raise ValueError(f"bins_per_octave={bins_per_octave} is not a multiple of n_chroma={n_chroma}")
    one_octave = np.roll(np.repeat(np.eye(n_chroma), merge, axis=1), -(merge // 2), axis=1)
    return np.tile(one_octave, int(np.ceil(n_bins / bins_per_octave)))[:, :n_bins].astype(np.float32)


def fold_chroma(cq: np.ndarray, bins_per_octave: int = 36, n_chroma: int = 12) -> np.ndarray:
    """``cq @ chroma_map(...).T`` for whole octaves of bins, by sums over reshaped axes (no BLAS)."""
    n_frames, n_bins = cq.shape
    if n_bins % bins_per_octave:
        return cq @ chroma_map(n_bins, bins_per_octave, n_chroma).T
    merge = bins_per_octave // n_chroma
    per_octave = cq.reshape(n_frames, n_bins // bins_per_octave, bins_per_octave).sum(axis=1)
    centred = np.roll(per_octave, merge // 2, axis=1)  # each class's bins, centred on it, side by side
    return centred.reshape(n_frames, n_chroma, merge).sum(axis=2)


def chroma_cqt(
    y: np.ndarray,
    rate: float,
    hop: int,
    tuning: float,
    n_octaves: int = 7,
    bins_per_octave: int = 36,
    n_chroma: int = 12,
) -> np.ndarray:
    """``(n_frames, n_chroma)`` float32 chroma: constant-Q magnitudes from C1 (shifted by ``tuning``
    bins) folded onto pitch classes, each frame divided by its maximum (frames of ~0 left as they are)."""
    n_bins = n_octaves * bins_per_octave
    fmin = C1 * 2.0 ** (tuning / bins_per_octave)
    cq = cqt_magnitude(y, rate, hop, fmin, n_bins, bins_per_octave)
    chroma = fold_chroma(cq, bins_per_octave, n_chroma)
    peak = chroma.max(axis=1, keepdims=True).astype(np.float64)
    peak[peak < np.finfo(np.float32).tiny] = 1.0
    return (chroma / peak).astype(np.float32)
