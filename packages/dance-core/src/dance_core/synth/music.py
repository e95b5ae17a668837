"""Synthesized songs for the synthetic choreography: a band of drums, bass, chords, keys and a lead.

Every song has a mean tempo (the caller's ``bpm``; anything from 70 to 180 works), a meter (3/4 or
4/4), a key, a chord progression, a groove from :data:`STYLES` and sections (intro, verse, chorus,
bridge, outro) of whole bars. Like a live band its tempo drifts slowly (up to ``drift``, a few
percent, smooth over tens of beats), so beats are not evenly spaced, and it may swing (off-beat
8ths or 16ths late by the ``swing`` ratio). Every note and hit is placed in musical time (beats)
and mapped to seconds through the integrated tempo curve. Instruments and levels vary per song
(:mod:`.instruments`): plucked or FM keys, a lead, an organ or strings pad, claps, shakers,
rides, toms; some intros and bridges drop the drums and keep only a bass or keys pulse on every
beat. A short room reverb and background noise (20-50 dB below the music) finish the mix. The
first beat comes within half a beat of the start, after a soft count-in where it fits. Beat and
downbeat times are returned as ground truth; everything is drawn from the ``rng`` passed in.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dance_core.synth import instruments as ins

BEATS_PER_BAR = 4  # the default meter's (4/4) beats per bar
STEPS = 4  # drum steps per beat (16th notes)


@dataclass(frozen=True)
class Groove:
    """A drum pattern: beats per bar, per drum its hits as 16th steps in the bar (``core`` in every
    drummed section, ``extra`` added in choruses), and whether it always swings."""

    beats_per_bar: int
    core: dict[str, tuple[int, ...]]
    extra: dict[str, tuple[int, ...]] = field(default_factory=dict)
    swung: bool = False


_E4, _E3, _S4, _S3 = tuple(range(0, 16, 2)), tuple(range(0, 12, 2)), tuple(range(16)), tuple(range(12))
STYLES = {
    "four-on-the-floor": Groove(4, {"kick": (0, 4, 8, 12), "clap": (4, 12), "hat": (2, 6, 10, 14)},
                                {"shaker": _S4, "open_hat": (2, 6, 10, 14)}),
    "backbeat": Groove(4, {"kick": (0, 8, 10), "snare": (4, 12), "hat": _E4}, {"shaker": _S4, "open_hat": (14,)}),
    "hiphop": Groove(4, {"kick": (0, 6, 8, 11), "snare": (4, 12), "hat": _S4}, {"clap": (4, 12), "rim": (7, 15)}),
    "latin": Groove(4, {"kick": (0, 4, 8, 12), "rim": (0, 3, 6, 10, 12), "hat": (0, 3, 4, 6, 8, 10, 12, 14)},
                    {"shaker": _S4, "tom1": (7, 15), "tom0": (14,)}),
    "shuffle": Groove(4, {"kick": (0, 8), "snare": (4, 12), "ride": _E4}, {"hat": (4, 12), "clap": (4, 12)}, True),
    "halftime": Groove(4, {"kick": (0, 3, 10), "snare": (8,), "hat": _E4}, {"clap": (8,), "shaker": _S4}),
    "dembow": Groove(4, {"kick": (0, 4, 8, 12), "rim": (3, 6, 11, 14), "hat": _E4}, {"snare": (6, 14), "shaker": _S4}),
    "waltz": Groove(3, {"kick": (0,), "snare": (4, 8), "hat": (0, 4, 8)}, {"shaker": _E3, "open_hat": (0,)}),
    "jazz-waltz": Groove(3, {"kick": (0,), "ride": (0, 4, 6, 8), "hat": (4, 8)}, {"rim": (8,)}, True),
    "rock-34": Groove(3, {"kick": (0, 6), "snare": (4, 8), "hat": _E3}, {"clap": (4, 8), "ride": (0, 4, 8)}),
}
_ACCENTED = {"hat", "open_hat", "shaker", "ride"}  # louder on the beat, so every beat is an onset
SECTIONS = {  # name -> (loudness, chance the drums drop out and bass or keys carry the pulse, chance of a lead)
    "intro": (0.6, 0.4, 0.0),
    "verse": (0.8, 0.0, 0.2),
    "chorus": (1.0, 0.0, 0.8),
    "bridge": (0.7, 0.3, 0.3),
    "outro": (0.6, 0.1, 0.2),
}
_PROGRESSIONS = ((0, 7, 9, 5), (0, 5, 7, 5), (9, 5, 0, 7), (0, 9, 5, 7), (0, 5, 9, 7), (0, 2, 5, 7))
_MINOR = {2, 4, 9}  # scale degrees (semitones above the key) whose triads are minor


@dataclass
class Song:
    """Audio and its ground truth.

    ``bpm`` is the mean tempo over the song's beats; ``beats`` the time in seconds of every beat
    (unevenly spaced when the tempo drifts) and ``downbeats`` those that start a bar (every
    ``beats_per_bar``-th, 3 or 4); ``sections`` are ``(name, start s, end s)`` and ``section_bars``
    ``(name, first bar, end bar)``; ``style`` names the groove (a key of :data:`STYLES`). ``swing``
    is the swing ratio (0.5: straight; 0.67: triplet feel) applied to off-beat ``swing_unit``-th
    notes (8 or 16); ``drift`` bounds the tempo drift: every beat interval lies within
    ``60 / bpm * (1 ± drift)`` of the caller's bpm.
    """

    audio: np.ndarray
    rate: int
    bpm: float
    beats: np.ndarray
    downbeats: np.ndarray
    sections: list[tuple[str, float, float]]
    style: str
    section_bars: list[tuple[str, int, int]]
    beats_per_bar: int = BEATS_PER_BAR
    swing: float = 0.5
    drift: float = 0.0
    swing_unit: int = 8


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


def swung(position: np.ndarray, swing: float, unit: int = 8) -> np.ndarray:
    """Positions in beats with swing: within every pair of ``unit``-th notes the second one starts at
    ``swing`` of the pair instead of half-way (the grid in between is stretched to match)."""
    span = 1.0 if unit == 8 else 0.5
    x = np.asarray(position, dtype=float) / span
    k = np.floor(x)
    f = x - k
    return (k + np.where(f < 0.5, f * 2 * swing, swing + (f - 0.5) * 2 * (1 - swing))) * span


def tempo_map(n_beats: int, bpm: float, drift: float, offset: float, rng: np.random.Generator,
              res: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """``(positions in beats, seconds)`` on a fine grid from -8 to ``n_beats`` + 8 beats: beat 0 at
    ``offset`` s, the beat period ``60 / bpm * (1 + drift * s(b))`` with ``s`` a smooth random curve
    (a few slow sines and a push or drag), zero mean over beats 0..``n_beats`` and ``|s| <= 1``."""
    b = np.arange(-8 * res, (n_beats + 8) * res + 1) / res
    s = rng.uniform(-1, 1) * b / max(1, n_beats)
    for _ in range(3):
        s = s + rng.uniform(0.3, 1.0) * np.sin(2 * np.pi * b / rng.uniform(12, 64) + rng.uniform(0, 2 * np.pi))
    inside = (b >= 0) & (b <= n_beats)
    s = s - s[inside].mean()
    s = np.clip(s / max(1e-9, np.abs(s[inside]).max()), -1, 1)
    period = 60.0 / bpm * (1 + drift * s)
    sec = np.concatenate([[0.0], np.cumsum((period[1:] + period[:-1]) / (2 * res))])
    return b, sec - sec[8 * res] + offset


class _Band:
    """The events of one song, by bus; notes are cached per sound and trimmed to their length."""

    def __init__(self, rate: int, clock, rng: np.random.Generator):
        self.rate, self.clock, self.rng = rate, clock, rng
        self.events: list[tuple[str, float, np.ndarray, float, float]] = []  # bus, beat, sound, gain, beats
        self.cache: dict[tuple, np.ndarray] = {}

    def hit(self, bus: str, beat: float, sound: np.ndarray, gain: float, beats: float = 0.0) -> None:
        """One event at musical time ``beat`` (swung later); ``beats > 0`` cuts the sound after that many beats."""
        self.events.append((bus, beat, sound, gain, beats))

    def note(self, bus: str, beat: float, key: tuple, make, gain: float, beats: float) -> None:
        """A cached tonal note (``make()`` on first use) lasting ``beats``."""
        if key not in self.cache:
            self.cache[key] = make()
        self.hit(bus, beat, self.cache[key], gain, beats)

    def mix(self, n: int, gains: dict[str, float]) -> dict[str, np.ndarray]:
        """Every bus rendered: events placed at their swung, drifting times with a little velocity jitter."""
        buses = {name: np.zeros(n) for name in gains}
        if not self.events:
            return buses
        starts = self.clock(np.array([e[1] for e in self.events]))
        ends = self.clock(np.array([e[1] + e[4] for e in self.events]))
        velocity = self.rng.uniform(0.85, 1.0, len(self.events))
        fade = np.linspace(1.0, 0.0, max(2, int(0.02 * self.rate)))
        for (bus, _, sound, gain, beats), t0, t1, v in zip(self.events, starts, ends, velocity, strict=True):
            i = int(round(t0 * self.rate))
            m = len(sound) if beats <= 0 else min(len(sound), int((t1 - t0) * self.rate))
            if i >= n or i + m <= 0 or m <= 0:
                continue
            s = sound[:m] * (gain * v)
            if beats > 0 and m > len(fade):
                s[-len(fade):] *= fade
            lo, hi = max(0, i), min(n, i + m)
            buses[bus][lo:hi] += s[lo - i:hi - i]
        return buses


#: samples mixed down at a time by :func:`_mixdown`
_PIECE = 1 << 16


def _mixdown(buses: dict[str, np.ndarray], levels: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The dry mix (every bus at its level) and the reverb's send (pad, keys and lead, a little drums),
    computed a piece at a time into the drums' and the lead's buses: no memory beyond the buses'."""
    dry, send = buses["drums"], buses["lead"]
    for i in range(0, len(dry), _PIECE):
        part = {k: bus[i:i + _PIECE] for k, bus in buses.items()}
        mixed = sum(levels[k] * part[k] for k in levels)
        send[i:i + _PIECE] = part["pad"] + part["keys"] + part["lead"] + 0.3 * part["drums"]
        dry[i:i + _PIECE] = mixed
    return dry, send


def _arrange(sections, groove: Groove, rng: np.random.Generator) -> list[dict]:
    """Per section: drums played, which instrument keeps the pulse without drums, bass, keys, lead, loudness."""
    out = []
    for name, first, end in sections:
        loud, p_sparse, p_lead = SECTIONS[name]
        sparse = rng.random() < p_sparse
        drums = dict(groove.core)
        if name in ("intro", "bridge"):
            drums = {k: v for k, v in drums.items() if k not in ("snare", "clap", "rim")}
        if name == "chorus":
            drums.update(groove.extra)
        out.append({"drums": {} if sparse else drums, "pulse": str(rng.choice(["bass", "keys"])) if sparse else None,
                    "keys": rng.random() < 0.6, "lead": rng.random() < p_lead, "loud": loud,
                    "fill": end - first >= 4 and rng.random() < 0.4,
                    "bass": sparse or name not in ("intro", "bridge")})  # light sections: drums and chords
    return out


def synthesize(seconds: float, bpm: float, rate: int, rng: np.random.Generator, style: str | None = None, *,
               beats_per_bar: int | None = None, swing: float | None = None, swing_unit: int | None = None,
               drift: float | None = None, snr_db: float | None = None) -> Song:
    """A song of ``seconds`` at a mean tempo of ``bpm`` (70-180); options not given are drawn from ``rng``:
    ``style`` (a groove of :data:`STYLES`, which fixes the meter), ``beats_per_bar`` (3 or 4), ``swing``
    (0.5-0.67) of ``swing_unit``-th notes (8 or 16), ``drift`` (0-0.04) and ``snr_db`` (20-50) of the noise."""
    if style is None:
        names = [k for k, g in STYLES.items() if beats_per_bar in (None, g.beats_per_bar)]
        if beats_per_bar is None:  # a third of the songs in 3/4
            names = [k for k in names if STYLES[k].beats_per_bar == (3 if rng.random() < 1 / 3 else 4)]
        style = str(rng.choice(names))
    groove = STYLES[style]
    bpb = groove.beats_per_bar
    if beats_per_bar not in (None, bpb):
        raise ValueError(f"synthesize: style {style!r} is in {bpb}/4, not {beats_per_bar}/4")
    if swing is None:
        swing = float(rng.uniform(0.6, 0.67)) if groove.swung else (
            float(rng.uniform(0.54, 0.67)) if rng.random() < 0.3 else 0.5)
    if swing_unit is None:
        swing_unit = 16 if len(groove.core.get("hat", ())) == 4 * bpb and rng.random() < 0.7 else 8
    drift = float(rng.uniform(0.005, 0.04) if rng.random() < 0.75 else 0.0) if drift is None else float(drift)
    snr_db = float(rng.uniform(20, 50)) if snr_db is None else float(snr_db)
    period = 60.0 / bpm
    offset = float(rng.uniform(0.05, 0.5)) * period
    n = int(round(seconds * rate))
    n_beats = int(seconds / period * (1 + drift)) + 2
    grid_b, grid_s = tempo_map(n_beats, bpm, drift, offset, rng)
    whole = grid_b == np.round(grid_b)
    beats = grid_s[whole & (grid_b >= 0)]
    beats = beats[beats < seconds]
    n_bars = int(np.ceil(len(beats) / bpb))
    sections = plan_sections(n_bars, rng)

    def clock(pos):
        return np.interp(swung(pos, swing, swing_unit), grid_b, grid_s)

    band = _Band(rate, clock, rng)
    kit = ins.drum_kit(rate, rng)
    key = 40 + int(rng.integers(0, 12))  # MIDI note of the bass root (E2..D#3)
    prog = _PROGRESSIONS[int(rng.integers(0, len(_PROGRESSIONS)))]
    bass_kind, pad_kind, keys_kind = (str(rng.choice(c)) for c in (("sine", "saw", "pluck"), ("organ", "strings"),
                                                                   ("pluck", "fm")))
    fm_ratio, fm_index = float(rng.choice([1.0, 2.0, 3.0, 3.5])), float(rng.uniform(1.0, 3.5))
    bar_s = float(np.diff(np.interp(np.arange(0, n_beats + bpb, bpb), grid_b, grid_s)).max())
    pad = ins.strings if pad_kind == "strings" else ins.organ
    voices = {  # name -> (sound of a MIDI note or chord, made once per pitch)
        "bass": lambda m: ins.bass(ins.hz(m), 2.0, rate, bass_kind),
        "pad": lambda c: pad([ins.hz(m) for m in c], bar_s * 1.05, rate),
        "stab": lambda c: sum(ins.fm_keys(ins.hz(m), 1.0, rate, 1.0, 1.5) for m in c) / 2,
        "keys": lambda m: (ins.pluck(ins.hz(m), 1.5, rate, rng) if keys_kind == "pluck"
                           else ins.fm_keys(ins.hz(m), 1.5, rate, fm_ratio, fm_index)),
        "lead": lambda m: ins.lead(ins.hz(m), 2.2 * bar_s / bpb, rate),
    }

    def play(bus: str, voice: str, beat: float, pitch, gain: float, beats: float) -> None:
        band.note(bus, beat, (voice, pitch), lambda: voices[voice](pitch), gain, beats)

    motif = rng.random(2 * bpb) < 0.45  # the keys' rhythm in 8ths, the same every bar
    motif[0] = True
    slots = np.flatnonzero(motif)
    kick = groove.core["kick"]
    for (name, first, end), part in zip(sections, _arrange(sections, groove, rng), strict=True):
        loud = part["loud"]
        for bar in range(first, end):
            b0 = bar * bpb
            degree = prog[bar % len(prog)]
            root = key + degree
            chord = (root + 12, root + (15 if degree in _MINOR else 16), root + 19)
            fill = part["fill"] and bar == end - 1 and part["drums"]
            for drum, steps in part["drums"].items():
                for s in steps:
                    if not (fill and s >= STEPS * (bpb - 1)):
                        band.hit("drums", b0 + s / STEPS, kit[drum], (3.5 if drum in _ACCENTED and s % STEPS == 0
                                                                      else 1.0) * loud)
            if fill:  # toms over the section's last beat
                for i, tom in enumerate(("tom2", "tom1", "tom1", "tom0")):
                    band.hit("drums", b0 + bpb - 1 + i / STEPS, kit[tom], loud * (1.5 if i == 0 else 1.0))
            if name == "chorus" and bar == first and part["drums"]:
                band.hit("drums", b0, kit["open_hat"], 3.0 * loud)  # a crash-like open hat
            if part["pulse"] == "bass":  # no drums: root and fifth on every beat
                hits = [(float(b), root + (7 if b % 2 else 0)) for b in range(bpb)]
            elif part["pulse"] == "keys":  # no drums: a chord stab on every beat over a held bass
                hits = [(0.0, root)]
                for b in range(bpb):
                    play("keys", "stab", b0 + b, chord, (1.3 if b == 0 else 1.0) * loud, 0.9)
            else:  # the bass follows the kick
                hits = [(s / STEPS, root + (12 if i == 2 and len(kick) > 3 else 0)) for i, s in enumerate(kick)]
            for i, (pos, m) in enumerate(hits if part["bass"] else []):
                nxt = hits[i + 1][0] if i + 1 < len(hits) else float(bpb)
                play("bass", "bass", b0 + pos, m, loud, min(2.0, nxt - pos))
            play("pad", "pad", b0, chord, loud, float(bpb))
            if part["keys"] and part["pulse"] is None:
                for j, slot in enumerate(slots):
                    m = chord[int(rng.integers(0, 3))] + 12 * int(rng.integers(0, 2))
                    nxt = slots[j + 1] if j + 1 < len(slots) else 2 * bpb
                    play("keys", "keys", b0 + slot / 2, m, 0.8 * loud, (nxt - slot) / 2)
            pos = 0.0
            while part["lead"] and pos < bpb:  # quarter and half notes of the major pentatonic
                length = float(rng.choice([1.0, 2.0])) if bpb - pos >= 2 else 1.0
                play("lead", "lead", b0 + pos, key + 24 + int(rng.choice([0, 2, 4, 7, 9, 12])), loud, length)
                pos += length
    for k in range(1, 16):  # a soft count-in of sticks on the 16ths before the first beat, where they fit
        if clock(np.array([-k / STEPS]))[0] >= 0.02:
            band.hit("drums", -k / STEPS, kit["sticks"], 0.6 / k)
    levels = {"drums": 1.0, "bass": float(rng.uniform(0.5, 1.2)), "pad": float(rng.uniform(0.4, 1.3)),
              "keys": float(rng.uniform(0.3, 0.9)), "lead": float(rng.uniform(0.2, 0.5))}
    audio, send = _mixdown(band.mix(n, levels), levels)
    wet_gain = float(rng.uniform(0.1, 0.35))
    wet = ins.reverb(send, rate, rng, float(rng.uniform(0.3, 1.2)))
    del send
    wet *= wet_gain
    audio += wet  # in place from here on: the same sums as before, a song at a time in about 50 bytes a sample
    del wet
    rms = float(np.sqrt(np.mean(audio**2))) or 1e-9
    noise_gain = rms * 10 ** (-snr_db / 20)
    noise = ins.background(n, rate, rng, float(rng.uniform(0.05, 0.3)))
    noise *= noise_gain
    audio += noise
    del noise
    peak = max(1e-9, np.abs(audio).max())
    audio *= 0.9
    audio /= peak
    downbeats = beats[::bpb]
    bar_t = lambda bar: float(np.interp(bar * bpb, grid_b, grid_s))  # noqa: E731
    sec = [(nm, bar_t(a), min(seconds, bar_t(b))) for nm, a, b in sections]
    mean_bpm = 60.0 * (len(beats) - 1) / (beats[-1] - beats[0]) if len(beats) > 1 else float(bpm)
    return Song(audio.astype(np.float32), rate, float(mean_bpm), beats, downbeats, sec, style, sections, bpb,
                float(swing), drift, int(swing_unit))
