"""Short-time Fourier transforms on centred frames, and their inverse.

Frame t is centred on sample ``centres[t]`` (``t * hop`` for a regular grid), zero padded past both
ends of the signal, as librosa's ``stft(center=True, pad_mode="constant")``. Spectra are returned
frames first, ``(n_frames, n_fft // 2 + 1)``, computed in float32 with ``scipy.fft`` on all cores.
"""

from __future__ import annotations

import numpy as np
import scipy.fft

CHUNK = 2048  # frames per FFT batch, bounding memory on long songs
TINY32 = np.finfo(np.float32).tiny


def periodic_hann(n: int, dtype: type = np.float32) -> np.ndarray:
    """The periodic (FFT) Hann window of ``n`` samples, computed as scipy's ``get_window("hann", n)``."""
    return (0.5 + 0.5 * np.cos(np.linspace(-np.pi, np.pi, n + 1)[:n])).astype(dtype)


def centred_frame_count(n_samples: int, hop: int) -> int:
    """Centred frames of a signal on a ``hop`` grid: frame t at sample ``t * hop <= n_samples``."""
    return 1 + n_samples // hop


def centred_frames(y: np.ndarray, n_fft: int, centres: np.ndarray) -> np.ndarray:
    """``(len(centres), n_fft)`` frames, frame t starting at ``centres[t] - n_fft // 2``, zero padded.

    Centres must lie in ``[0, len(y)]``. An evenly spaced grid gives a strided view (no copy).
    """
    half = n_fft // 2
    padded = np.pad(np.asarray(y, dtype=np.float32), (half, n_fft - half))
    centres = np.asarray(centres, dtype=np.int64)
    if len(centres) > 1 and np.all(np.diff(centres) == centres[1] - centres[0]) and centres[1] > centres[0]:
        step = int(centres[1] - centres[0])
        view = np.lib.stride_tricks.sliding_window_view(padded, n_fft)
        return view[centres[0] : centres[0] + step * len(centres) : step]
    return padded[centres[:, None] + np.arange(n_fft)[None, :]]


def _window(window: str | np.ndarray, n_fft: int) -> np.ndarray | None:
    """The analysis window as float32, or ``None`` for a box (no multiplication)."""
    if isinstance(window, str):
        if window == "hann":
            return periodic_hann(n_fft)
        if window == "box":
            return None
        raise ValueError(f"unknown window {window!r} (hann, box or an array)")
    return np.asarray(window, dtype=np.float32)


def stft_at(
    y: np.ndarray, centres: np.ndarray, n_fft: int, window: str | np.ndarray = "hann", power: bool = False
) -> np.ndarray:
    """Spectra of the frames centred at ``centres``: complex64, or float32 ``|X|**2`` if ``power``.

    ``window`` is ``"hann"`` (periodic), ``"box"`` or an array of ``n_fft`` values; FFTs run in
    chunks of :data:`CHUNK` frames.
    """
    frames = centred_frames(y, n_fft, centres)
    win = _window(window, n_fft)
    out = None
    for lo in range(0, len(frames), CHUNK):
        chunk = frames[lo : lo + CHUNK]
        windowed = np.ascontiguousarray(chunk) if win is None else chunk * win  # (faster than strided FFT input)
        spec = scipy.fft.rfft(windowed, axis=1, workers=-1)
        if power:
            spec = np.abs(spec) ** 2
        if len(frames) <= CHUNK:
            return spec
        if out is None:
            out = np.empty((len(frames), n_fft // 2 + 1), dtype=spec.dtype)
        out[lo : lo + CHUNK] = spec
    return out if out is not None else np.zeros((0, n_fft // 2 + 1), np.float32 if power else np.complex64)


def stft(y: np.ndarray, n_fft: int, hop: int, window: str | np.ndarray = "hann") -> np.ndarray:
    """``(1 + len(y) // hop, n_fft // 2 + 1)`` complex64 spectra of frames centred at ``t * hop``."""
    return stft_at(y, np.arange(centred_frame_count(len(y), hop)) * hop, n_fft, window)


def _overlap_add(frames: np.ndarray, hop: int) -> np.ndarray:
    """Sum ``(T, n)`` frames placed at samples ``t * hop``, as ``(T + ceil(n / hop) - 1, hop)`` rows."""
    n_frames, n = frames.shape
    blocks = -(-n // hop)
    if blocks * hop != n:
        frames = np.pad(frames, ((0, 0), (0, blocks * hop - n)))
    parts = frames.reshape(n_frames, blocks, hop)
    out = np.zeros((n_frames + blocks - 1, hop), dtype=frames.dtype)
    for b in range(blocks):
        out[b : b + n_frames] += parts[:, b]
    return out


def _normalise_by_window(rows: np.ndarray, window: np.ndarray, n_frames: int) -> None:
    """Divide overlap-added ``rows`` (as :func:`_overlap_add` returns) by the sum of the squared
    windows over them, in place, wherever that sum is not ~0. Rows covered by every block of the
    window share one sum; only the first and last few are summed on their own."""
    n_rows, hop = rows.shape
    blocks = n_rows - n_frames + 1
    squares = np.zeros(blocks * hop, dtype=np.float32)
    squares[: len(window)] = window.astype(np.float32) ** 2
    squares = squares.reshape(blocks, hop)
    full = squares.sum(axis=0)
    middle = rows[blocks - 1 : n_frames]
    np.divide(middle, full, out=middle, where=full > TINY32)
    for j in [*range(min(blocks - 1, n_rows)), *range(max(blocks - 1, n_frames), n_rows)]:
        envelope = squares[max(0, j - n_frames + 1) : min(blocks, j + 1)].sum(axis=0)
        np.divide(rows[j], envelope, out=rows[j], where=envelope > TINY32)


def istft(spec: np.ndarray, hop: int, length: int, window: str | np.ndarray = "hann") -> np.ndarray:
    """The signal of ``length`` samples whose centred STFT (as :func:`stft`) is closest to ``spec``.

    Windowed inverse FFTs are overlap-added and divided by the summed squared window, wherever that
    sum is not ~0 (librosa's ``istft(center=True, length=...)``).
    """
    n_fft = 2 * (spec.shape[1] - 1)
    half = n_fft // 2
    window = _window(window, n_fft)
    window = np.ones(n_fft, np.float32) if window is None else window
    n_frames = min(len(spec), -(-(length + 2 * half) // hop))
    frames = scipy.fft.irfft(spec[:n_frames], n=n_fft, axis=1, workers=-1)
    frames *= window
    rows = _overlap_add(frames, hop)
    _normalise_by_window(rows, window, n_frames)
    y = rows.reshape(-1)[half : half + length]
    return np.pad(y, (0, length - len(y))) if len(y) < length else y.copy()
