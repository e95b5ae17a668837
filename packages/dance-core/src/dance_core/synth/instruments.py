"""Instrument voices for :mod:`dance_core.synth.music`, in plain numpy.

Drums are decaying sines and shaped noise; basses, keys, leads and pads are additive or FM tones;
plucks are Karplus-Strong strings. Every voice is a float64 array at ``rate`` Hz; partials above
0.45 ``rate`` are left out, so any rate from 4 kHz up works. The room is a
convolution with a short decaying noise burst.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter, oaconvolve


def hz(midi: float) -> float:
    """Frequency of a MIDI note number."""
    return 440.0 * 2 ** ((midi - 69) / 12)


def _t(seconds: float, rate: int) -> np.ndarray:
    return np.arange(max(1, int(seconds * rate))) / rate


def _partials(f: float, t: np.ndarray, amps, rate: int, phase: np.ndarray | None = None) -> np.ndarray:
    """Sum of harmonics ``k f`` with amplitudes ``amps[k-1]`` (``phase``: a running phase in cycles of f)."""
    ph = f * t if phase is None else phase
    out = np.zeros(len(t))
    for k, a in enumerate(amps, 1):
        if k * f < 0.45 * rate and a:
            out += a * np.sin(2 * np.pi * k * ph)
    return out


def _hp(x: np.ndarray) -> np.ndarray:
    return np.diff(x, prepend=0.0)


def _bp(x: np.ndarray, rate: int, lo_ms: float) -> np.ndarray:
    """Noise less its moving average over ``lo_ms`` (a crude high-pass)."""
    w = max(1, int(lo_ms * rate / 1000))
    return x - np.convolve(x, np.ones(w) / w, mode="same")


def drum_kit(rate: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """One song's drum sounds, slightly different every draw: kick, snare, clap, closed and open hats,
    shaker, ride, rim, three toms and soft sticks (the count-in)."""
    t = _t(0.6, rate)
    noise = rng.standard_normal(len(t))
    f0, sweep, tau = rng.uniform(42, 60), rng.uniform(60, 120), rng.uniform(0.09, 0.16)
    kick = np.sin(2 * np.pi * (f0 * t + sweep * 0.04 * (1 - np.exp(-t / 0.04)))) * np.exp(-t / tau)
    kick += 0.6 * _hp(noise) * np.exp(-t / 0.005)  # beater click, a broadband onset
    body = rng.uniform(160, 240)
    snare = (0.7 * _bp(noise, rate, 1.0) + 0.5 * np.sin(2 * np.pi * body * t)) * np.exp(-t / rng.uniform(0.05, 0.1))
    burst = np.zeros(len(t))
    for k in range(4):  # a clap: a few hands within 30 ms, then a short tail
        d = int((0.008 * k + rng.uniform(0, 0.003)) * rate)
        burst[d:] += np.exp(-t[: len(t) - d] / (0.006 if k < 3 else 0.06))
    clap = _bp(noise, rate, 0.7) * burst
    hat_noise = _hp(_hp(rng.standard_normal(len(t))))
    hat = hat_noise * np.exp(-t / rng.uniform(0.012, 0.03))
    open_hat = hat_noise * np.exp(-t / rng.uniform(0.12, 0.2))
    shaker = _hp(noise) * np.minimum(1.0, t / 0.008) * np.exp(-t / 0.035)
    bell_f = 512.0 * rng.uniform(0.95, 1.05) * np.array([1, 1.47, 2.09, 2.56, 3.3])  # inharmonic, metallic
    bell = sum(np.sin(2 * np.pi * f * t) for f in bell_f if f < 0.45 * rate)
    ride = (0.35 * bell + 0.5 * hat_noise) * np.exp(-t / 0.35)
    rim = (np.sin(2 * np.pi * min(1700.0, 0.4 * rate) * t) + 0.3 * noise) * np.exp(-t / 0.012)
    toms = {f"tom{i}": np.sin(2 * np.pi * (f * t + 20 * 0.05 * (1 - np.exp(-t / 0.05)))) * np.exp(-t / 0.22)
            for i, f in enumerate((85.0, 125.0, 175.0))}
    sticks = _bp(noise, rate, 0.3) * np.exp(-t / 0.006)
    kit = {"kick": 0.9 * kick, "snare": 0.45 * snare, "clap": 0.5 * clap, "hat": 0.03 * hat,
           "open_hat": 0.02 * open_hat, "shaker": 0.08 * shaker, "ride": 0.12 * ride, "rim": 0.25 * rim,
           "sticks": 0.2 * sticks}
    kit.update({k: 0.5 * v for k, v in toms.items()})
    return kit


def bass(f: float, seconds: float, rate: int, kind: str) -> np.ndarray:
    """A bass note: ``sine`` (saturated sine), ``saw`` (bright, filtered by decay) or ``pluck`` (short)."""
    t = _t(seconds, rate)
    if kind == "saw":
        tone = _partials(f, t, [0.6 / k * np.exp(-(k - 1) * 0.35) for k in range(1, 9)], rate)
        return tone * np.exp(-t / 0.4) * np.minimum(1.0, t / 0.004)
    tone = np.tanh(2 * np.sin(2 * np.pi * f * t))
    return 0.7 * tone * np.exp(-t / (0.12 if kind == "pluck" else 0.3)) * np.minimum(1.0, t / 0.003)


def pluck(f: float, seconds: float, rate: int, rng: np.random.Generator, damping: float = 0.996) -> np.ndarray:
    """A Karplus-Strong plucked string: a noise burst fed back through a one-period delay and a
    two-point average; computed one period at a time."""
    n, p = max(1, int(seconds * rate)), max(2, int(round(rate / f)))
    y = np.zeros(n + 2 * p + 1)
    y[:p + 1] = rng.uniform(-1, 1, p + 1)
    for k in range(1, (n + p) // p + 1):
        a, b = k * p + 1, min(len(y), (k + 1) * p + 1)
        y[a:b] = damping * 0.5 * (y[a - p:b - p] + y[a - p - 1:b - p - 1])
    return 0.6 * y[:n]


def fm_keys(f: float, seconds: float, rate: int, ratio: float = 1.0, index: float = 2.0) -> np.ndarray:
    """An electric-piano-like FM tone: the modulation index decays faster than the note."""
    t = _t(seconds, rate)
    mod = index * np.exp(-t / 0.15) * np.sin(2 * np.pi * ratio * f * t) if ratio * f < 0.45 * rate else 0.0
    return 0.5 * np.sin(2 * np.pi * f * t + mod) * np.exp(-t / 0.6) * np.minimum(1.0, t / 0.002)


def lead(f: float, seconds: float, rate: int, bright: float = 0.5, vibrato: float = 5.5) -> np.ndarray:
    """A synth lead: odd-heavy harmonics with delayed vibrato and a soft attack and release."""
    t = _t(seconds, rate)
    depth = 0.004 * np.minimum(1.0, t / 0.3)
    phase = f * t + f * depth * np.sin(2 * np.pi * vibrato * t) / (2 * np.pi * vibrato)
    amps = [(1.0 if k % 2 else bright) / k**1.5 for k in range(1, 8)]
    env = np.minimum(1.0, t / 0.02) * np.minimum(1.0, (t[-1] - t) / 0.05 + 1e-3)
    return 0.25 * _partials(f, t, amps, rate, phase) * env


def strings(freqs, seconds: float, rate: int, attack: float = 0.25) -> np.ndarray:
    """A strings-like pad: each note three detuned saw-ish tones, slow attack, release at the end."""
    t = _t(seconds, rate)
    out = np.zeros(len(t))
    for f in freqs:
        for d in (0.997, 1.0, 1.004):
            out += _partials(f * d, t, [1 / k for k in range(1, 7)], rate)
    env = np.minimum(1.0, t / attack) * np.minimum(1.0, (t[-1] - t) / 0.15 + 1e-3)
    return 0.03 * out * env


def organ(freqs, seconds: float, rate: int) -> np.ndarray:
    """A soft sine pad (the original chord pad): quick fade in, fade out at the end."""
    t = _t(seconds, rate)
    env = np.minimum(1.0, t / 0.05) * np.minimum(1.0, (t[-1] - t) / 0.1 + 1e-3)
    return 0.06 * sum(np.sin(2 * np.pi * f * t) + 0.2 * np.sin(4 * np.pi * f * t) * (2 * f < 0.45 * rate)
                      for f in freqs) * env


def reverb(x: np.ndarray, rate: int, rng: np.random.Generator, seconds: float) -> np.ndarray:
    """The room's answer to ``x``: its convolution with a unit-energy decaying noise burst whose level
    falls 60 dB in ``seconds``, cut to ``len(x)``; computed at about 5.5 kHz (a dull, cheap room)."""
    q = max(1, rate // 5500)
    m = len(x) // q * q
    low = x[:m].reshape(-1, q).mean(axis=1) if q > 1 else x
    t = _t(seconds, rate // q)
    ir = rng.standard_normal(len(t)) * np.exp(-6.9 * t / seconds) * np.minimum(1.0, t / 0.01)
    wet = oaconvolve(low, ir / np.sqrt((ir**2).sum()))[: len(low)]
    centres, out, piece = np.arange(len(low)) * q + (q - 1) / 2, np.empty(len(x)), 1 << 16
    for i in range(0, len(x), piece):  # back at ``rate``, a piece at a time
        out[i:i + piece] = np.interp(np.arange(i, min(i + piece, len(x)), dtype=np.float64), centres, wet)
    return out


def background(n: int, rate: int, rng: np.random.Generator, hiss: float) -> np.ndarray:
    """Unit-RMS background noise: roughly pink (one-pole low-passes of white noise at decade-spaced
    corners, each weighted by one over the square root of its corner) plus ``hiss`` (0..1) of white."""
    white = rng.standard_normal(n)
    pink = np.zeros(n)
    for fc in (20.0, 200.0, 2000.0):  # in place: three arrays of n at most (and std's one)
        p = np.exp(-2 * np.pi * fc / rate)
        low = lfilter([1 - p], [1, -p], white)
        low /= np.sqrt(fc)
        pink += low
        del low
    pink /= max(1e-12, pink.std())
    white *= hiss
    pink += white
    del white
    pink /= max(1e-12, pink.std())
    return pink
