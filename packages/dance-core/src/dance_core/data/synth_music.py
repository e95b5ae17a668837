"""Synthesized songs for the synthetic choreography: drums, bass and chords over bars and sections.

Every song is a tempo (beats per minute), a key, a chord progression, a drum pattern in one of a
few genre-like styles, and a sequence of sections (intro, verse, chorus, bridge, outro) of whole
bars in 4/4. Beat and downbeat times are returned as ground truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BEATS_PER_BAR = 4
#: drum hits per style as 16th-note steps within a bar: kick, snare, hi-hat (hats mark every beat)
STYLES = {
    "four-on-the-floor": ((0, 4, 8, 12), (4, 12), (2, 6, 10, 14)),
    "backbeat": ((0, 8, 10), (4, 12), (0, 2, 4, 6, 8, 10, 12, 14)),
    "hiphop": ((0, 6, 8, 11), (4, 12), tuple(range(16))),
    "latin": ((0, 7, 8, 15), (6, 14), (0, 3, 4, 6, 8, 10, 12, 14)),
}
SECTIONS = {  # name -> (drum parts, bass, chords, loudness); every section keeps the beat audible
    "intro": (("kick", "hat"), False, True, 0.6),
    "verse": (("kick", "snare", "hat"), True, True, 0.8),
    "chorus": (("kick", "snare", "hat"), True, True, 1.0),
    "bridge": (("kick", "hat"), False, True, 0.7),
    "outro": (("kick", "snare", "hat"), True, True, 0.6),
}
_PROGRESSIONS = ((0, 7, 9, 5), (0, 5, 7, 5), (9, 5, 0, 7), (0, 9, 5, 7))  # semitones: I-V-vi-IV etc.


@dataclass
class Song:
    """Audio and its ground truth: beats, downbeats, sections ``(name, start s, end s)``, style."""

    audio: np.ndarray
    rate: int
    bpm: float
    beats: np.ndarray
    downbeats: np.ndarray
    sections: list[tuple[str, float, float]]
    style: str
    section_bars: list[tuple[str, int, int]]


def plan_sections(n_bars: int, rng: np.random.Generator) -> list[tuple[str, int, int]]:
    """Sections as ``(name, first bar, end bar)``: an intro, verse/chorus pairs, maybe a bridge, an outro."""
    plan: list[tuple[str, int]] = [("intro", int(rng.choice([2, 4])))]
    order = ["verse", "chorus", "verse", "chorus", "bridge", "chorus"]
    i = 0
    while sum(n for _, n in plan) < n_bars:
        plan.append((order[i % len(order)], int(rng.choice([4, 8]))))
        i += 1
    out, start = [], 0
    for name, n in plan:
        end = min(start + n, n_bars)
        if end > start:
            out.append((name, start, end))
        start = end
    if len(out) > 2 and out[-1][2] - out[-1][1] >= 2:
        out[-1] = ("outro", out[-1][1], out[-1][2])
    return out


def _place(buf: np.ndarray, start: int, sound: np.ndarray) -> None:
    end = min(len(buf), start + len(sound))
    if 0 <= start < len(buf):
        buf[start:end] += sound[: end - start]


def _drum_kit(rate: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    t = np.arange(int(0.35 * rate)) / rate
    kick = np.sin(2 * np.pi * (45 * t + 90 * 0.05 * (1 - np.exp(-t / 0.05)))) * np.exp(-t / 0.12)
    n = rng.standard_normal(len(t))
    snare = (0.6 * n + 0.5 * np.sin(2 * np.pi * 190 * t)) * np.exp(-t / 0.07)
    hat = np.diff(n, prepend=0.0) * np.exp(-t / 0.015)
    return {"kick": 0.9 * kick, "snare": 0.45 * snare, "hat": 0.12 * hat}


def synthesize(seconds: float, bpm: float, rate: int, rng: np.random.Generator, style: str | None = None) -> Song:
    """A song of ``seconds`` at ``bpm``: drums in a genre-like style, a bass line and chord pads."""
    style = style or str(rng.choice(list(STYLES)))
    period = 60.0 / bpm
    offset = float(rng.uniform(0.05, 0.5)) * period
    n = int(round(seconds * rate))
    beats = np.arange(offset, seconds, period)
    n_bars = int(np.ceil(len(beats) / BEATS_PER_BAR))
    sections = plan_sections(n_bars, rng)
    key = 40 + int(rng.integers(0, 12))  # MIDI note of the bass root (E2..D#3)
    prog = _PROGRESSIONS[int(rng.integers(0, len(_PROGRESSIONS)))]
    kit = _drum_kit(rate, rng)
    kick_steps, snare_steps, hat_steps = STYLES[style]
    drums, bass, pads = np.zeros(n), np.zeros(n), np.zeros(n)
    step = period / 4
    bar_len = int(period * BEATS_PER_BAR * rate)
    tb = np.arange(bar_len) / rate
    env = np.minimum(1.0, tb / 0.05) * np.minimum(1.0, (tb[-1] - tb) / 0.1 + 1e-3)
    for name, first, end in sections:
        drum_parts, has_bass, has_chords, loud = SECTIONS[name]
        for bar in range(first, end):
            t0 = offset + bar * BEATS_PER_BAR * period
            root = key + prog[bar % len(prog)]
            f_root = 440.0 * 2 ** ((root - 69) / 12)
            for name_, steps in (("kick", kick_steps), ("snare", snare_steps), ("hat", hat_steps)):
                if name_ in drum_parts:
                    for s in steps:
                        accent = 3.0 if name_ == "hat" and s % 4 == 0 else 1.0  # hats accent the beat
                        _place(drums, int(round((t0 + s * step) * rate)), accent * loud * kit[name_])
            if has_bass:
                tn = np.arange(int(step * 3 * rate)) / rate
                note = np.tanh(2 * np.sin(2 * np.pi * f_root * tn)) * np.exp(-tn / 0.25) * 0.35 * loud
                for s in kick_steps:
                    _place(bass, int(round((t0 + s * step) * rate)), note)
            if has_chords:
                minor = prog[bar % len(prog)] == 9
                chord = [12, 15 if minor else 16, 19]
                pad = sum(np.sin(2 * np.pi * f_root * 2 ** (c / 12) * tb) for c in chord) * env * 0.06 * loud
                _place(pads, int(round(t0 * rate)), pad)
    # music begins at the first beat's bar; before it only a soft count-in of hats
    for b in np.arange(offset - period, -1e-9, -period)[::-1]:
        _place(drums, int(round(b * rate)), 0.5 * kit["hat"])
    audio = drums + bass + pads
    audio = 0.9 * audio / max(1e-9, np.abs(audio).max())
    sec = [(nm, offset + a * BEATS_PER_BAR * period, min(seconds, offset + b * BEATS_PER_BAR * period))
           for nm, a, b in sections]
    return Song(audio.astype(np.float32), rate, bpm, beats, beats[::BEATS_PER_BAR], sec, style, sections)
