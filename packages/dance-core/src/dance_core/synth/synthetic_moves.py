"""The ``synthetic-moves`` dataset: text-motion clips of the synthetic dancer, one move each, no music.

TM2D trains its text branch on a text-motion corpus (HumanML3D in the paper: motions of 2-10 s, each
with several descriptions and no music), disjoint from its music-dance pairs. This is that corpus for
the dancer of :mod:`dance_core.synth.dancer`: clip ``i`` performs one labelled move alone (the
moves are dealt in turn, so every move has as many clips as the others, give or take one) for a random
length (stretched, up to the longest allowed, to hold at least one whole bar of the move), to a random
tempo and meter, in a random style (amplitude, groove depth, arm carriage, lead side, walking speed),
optionally rising from and settling into the rest pose (standing, arms down) at either end; its
text, one of the move's :data:`~dance_core.synth.dancer.PHRASINGS`, covers the whole clip.
Deterministic from the seed: clip ``i`` draws everything from ``(seed, i)``.

No music: a source without audio would reach the feature extractors with ``audio=None``, which every
music extractor refuses ("... features need audio"). So every clip carries a *silent* ``Audio`` as long
as its motion: music extractors run unchanged, clips of the music-dance and text-motion corpora have
the same streams when mixed (:mod:`dance_core.data.mix`), and silence is the "no music" signal (a
model tells the corpora apart by it and by the text stream, all ``<pad>`` on music-dance clips whose
texts were dropped).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from dance_core.data.sources import ClipSource
from dance_core.media import Audio, TextSpan, frame_count
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat, quat_mul, quat_rotate, yaw_quat
from dance_core.motion.skeletons import dance24
from dance_core.synth.beat_grid import BeatGrid
from dance_core.synth.dancer import NAMES, PHRASINGS, STAND, Style, _pose
from dance_core.synth.synthetic_dance import _motion_data

#: a stream of draws of its own: the same seed gives synthetic-dance and synthetic-moves unrelated clips
STREAM = 0x6D6F7665
#: longest rest (hold + transition) at either end of a clip, seconds and fraction of the clip
REST_SECONDS, REST_FRACTION = 1.2, 0.2


def envelope(t: np.ndarray, seconds: float, rest_in: float, rest_out: float) -> np.ndarray:
    """How much of the move is danced at times ``t``: 0 in the rest pose, 1 in the move. ``rest_in`` and
    ``rest_out`` (seconds, 0 for none) are the rest at either end: a hold for 40 % of it, then a smooth
    transition over the rest."""
    def ramp(x: np.ndarray, length: float) -> np.ndarray:
        if length <= 0:
            return np.ones_like(x)
        u = np.clip((x - 0.4 * length) / (0.6 * length), 0.0, 1.0)
        return u * u * (3 - 2 * u)

    return ramp(t, rest_in) * ramp(seconds - t, rest_out)


def perform(move: str, grid: BeatGrid, seconds: float, fps: float, style: Style,
            rest_in: float = 0.0, rest_out: float = 0.0) -> Motion:
    """One move danced alone on ``grid``'s count for ``seconds``, blended from and into the rest pose
    over ``rest_in`` / ``rest_out`` seconds (the dancer's own pose functions, integrated as it does)."""
    n = frame_count(seconds, fps)
    t = np.arange(n) / fps
    bpb = grid.beats_per_bar
    beat = grid.beat_at(t)
    phi = beat - bpb * np.floor(beat / bpb)
    rot, off, rate = _pose(move, beat, phi, bpb, style)
    # the rest pose: the dancer's base pose in this style (no move, no groove)
    rest, _, _ = _pose("bounce", np.zeros(1), np.zeros(1), bpb, replace(style, amplitude=0.0, groove=0.0))
    w = envelope(t, seconds, rest_in, rest_out)
    rot = rest + w[:, None, None] * (rot - rest)
    off, rate = w[:, None] * off, w[:, None] * rate
    d_beat = np.diff(beat, prepend=2 * beat[0] - beat[1] if n > 1 else beat[0])  # beats per frame
    yaw = np.cumsum(rate[:, 2] * d_beat)
    h = yaw_quat(yaw)
    step = quat_rotate(h, np.stack([rate[:, 0], np.zeros(n), rate[:, 1]], -1)) * d_beat[:, None]
    root = np.cumsum(step, axis=0) + quat_rotate(h, off * np.array([1.0, 0.0, 1.0])) + np.array([0.0, STAND, 0.0])
    root[:, 1] += off[:, 1]
    quats = expmap_to_quat(rot)
    quats[:, 0] = quat_mul(h, quats[:, 0])
    return Motion(dance24(), fps, root, quats)


def make_move_clip(index: int, *, seed: int, seconds: tuple[float, float], bpm: tuple[float, float],
                   rate: int, fps: float, moves: list[str] | None = None, rest: float = 0.5) -> ClipSource:
    """Clip ``index``: move ``moves[index % len(moves)]`` alone, with silent audio and one phrasing of it."""
    moves = list(moves or NAMES)
    move = moves[index % len(moves)]
    rng = np.random.default_rng([seed, STREAM, index])
    length = float(rng.uniform(*seconds))
    period = 60.0 / float(rng.uniform(*bpm))
    bpb = 3 if rng.random() < 1 / 3 else 4
    first = float(rng.uniform(0.0, period))  # the count starts anywhere in a beat...
    downbeat = int(rng.integers(bpb))  # ...and anywhere in a bar
    style = Style.draw(rng)
    text = str(rng.choice(PHRASINGS[move]))
    room = min(REST_SECONDS, REST_FRACTION * length)
    rested, share = rng.random(2) < rest, rng.uniform(0.5, 1.0, 2)
    rest_in, rest_out = (float(share[k] * room) if rested[k] else 0.0 for k in range(2))
    # a whole bar of the move at full strength (a spin turns once a bar), as far as the longest length allows
    length = round(min(max(length, bpb * period + rest_in + rest_out), seconds[1]), 3)
    times = first - period + period * np.arange(int(np.ceil(length / period)) + 3)
    grid = BeatGrid(times, bpb, downbeat)
    motion = perform(move, grid, length, fps, style, rest_in, rest_out)
    audio = Audio(np.zeros(int(np.ceil(round(length * rate, 6))), np.float32), rate)
    inside = np.flatnonzero((times >= 0) & (times <= length))  # the count's beats within the clip
    downbeats = [float(b) for b in grid.downbeats() if 0 <= b <= length]
    meta = {"move": move, "bpm": grid.bpm, "beats": times[inside].tolist(), "downbeats": downbeats,
            "beats_per_bar": bpb, "first_downbeat": int((grid.first_downbeat - inside[:1].sum()) % bpb), "sections": [],
            "style": "silence", "rest": [rest_in, rest_out], "captions": [text]}
    return ClipSource(f"move-{index:04d}-{move}", _motion_data(motion, meta), audio,
                      texts=(TextSpan(text, 0.0, length),), meta=meta)


class SyntheticMoves:
    """The ``synthetic-moves`` dataset."""

    def __init__(self, config: Any, fps: float):
        self.config = config
        self.fps = config.motion_fps or fps

    def clip(self, index: int) -> ClipSource:
        """One clip."""
        c = self.config
        return make_move_clip(index, seed=c.seed, seconds=tuple(c.seconds), bpm=tuple(c.bpm), rate=c.sample_rate,
                              fps=self.fps, moves=c.moves, rest=c.rest)

    def clips(self) -> list[ClipSource]:
        """All ``clips`` clips."""
        return [self.clip(i) for i in range(self.config.clips)]


def build(config: Any, *, fps: float, **_: Any) -> SyntheticMoves:
    """Build the ``synthetic-moves`` dataset."""
    return SyntheticMoves(config, fps)
