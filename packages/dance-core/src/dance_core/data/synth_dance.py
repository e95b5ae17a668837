"""A beat-locked dancer on the SMPL-24 skeleton: moves chosen per bar, with timed text labels.

Every move is a pose function of musical time (a :class:`~dance_core.data.beat_grid.BeatGrid`:
beats since the first downbeat, on even or uneven beats, in bars of 2-7 beats): joint rotations as
exponential maps, periodic root offsets and root rates (travel, turning, per beat) that are
integrated over time. A groove shared by all moves dips the hips on every beat, so the hip's
height minima (its zero vertical velocity at the bottom) sit on the music's beats. Moves change at
bar lines with half a beat of blending; which move comes when depends on the section and a seed,
so one song admits many dances. :data:`PHRASINGS` words each move several ways (the captions of the
``synthetic-moves`` text-motion clips); :func:`all_texts` lists every text the dancer can produce.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dance_core.data.beat_grid import BeatGrid
from dance_core.media import TextSpan, frame_count
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat, quat_mul, quat_rotate, yaw_quat
from dance_core.motion.skeletons import SMPL_REST, smpl24

MOVES = {
    "bounce": "a person bounces to the beat",
    "step-touch": "a person steps from side to side",
    "sway": "a person sways their hips and arms",
    "arm-wave": "a person waves their arms overhead",
    "clap": "a person claps on the beat",
    "spin": "a person spins around",
    "jump": "a person jumps on the beat",
    "kick": "a person kicks their legs forward",
    "walk": "a person walks in a circle",
}
NAMES = list(MOVES)
#: several wordings of each move (the first is its label in MOVES): the captions of text-motion clips
PHRASINGS = {
    "bounce": (MOVES["bounce"], "someone bobs up and down in place", "the dancer bounces on their knees",
               "a person grooves in place, bending the knees on every beat"),
    "step-touch": (MOVES["step-touch"], "someone steps left and right", "the dancer sidesteps back and forth",
                   "a person shuffles sideways and back again"),
    "sway": (MOVES["sway"], "someone rocks their body from side to side", "the dancer sways gently",
             "a person leans left and right, swinging the arms"),
    "arm-wave": (MOVES["arm-wave"], "someone raises both arms and waves them", "the dancer waves both hands in the air",
                 "a person lifts the arms above the head and ripples them"),
    "clap": (MOVES["clap"], "someone claps their hands", "the dancer claps along to the rhythm",
             "a person brings the hands together again and again"),
    "spin": (MOVES["spin"], "someone turns around in place", "the dancer twirls on the spot",
             "a person rotates all the way around"),
    "jump": (MOVES["jump"], "someone hops up and down", "the dancer jumps in place",
             "a person leaps into the air again and again"),
    "kick": (MOVES["kick"], "someone kicks one leg and then the other", "the dancer alternates forward kicks",
             "a person swings each foot out in front"),
    "walk": (MOVES["walk"], "someone walks around in a circle", "the dancer strolls in a loop",
             "a person paces around in a ring"),
}
#: preference of each section for each move (same order as MOVES)
SECTION_WEIGHTS = {
    "intro": (4, 2, 4, 1, 2, 0, 0, 0, 1),
    "verse": (3, 4, 3, 2, 3, 1, 1, 1, 2),
    "chorus": (1, 2, 1, 4, 2, 3, 4, 3, 1),
    "bridge": (2, 1, 4, 3, 1, 2, 1, 1, 3),
    "outro": (4, 2, 4, 1, 2, 0, 0, 0, 0),
}
(PELVIS, L_HIP, R_HIP, SPINE1, L_KNEE, R_KNEE, SPINE2, L_ANKLE, R_ANKLE, SPINE3, L_FOOT, R_FOOT, NECK,
 L_COLLAR, R_COLLAR, HEAD, L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_WRIST, R_WRIST, L_HAND, R_HAND) = range(24)
#: root height when standing: the pelvis above the lowest foot joint, plus the foot's thickness
STAND = float(SMPL_REST[0, 1] - SMPL_REST[[10, 11], 1].min() + 0.03)
THIGH = float(np.linalg.norm(SMPL_REST[4] - SMPL_REST[1]))


@dataclass
class Style:
    """Per-dance variation: amplitude, groove depth, arm carriage, lead side, speed."""

    amplitude: float
    groove: float
    arms: float
    lead: float
    speed: float

    @classmethod
    def draw(cls, rng: np.random.Generator) -> Style:
        """A random style."""
        return cls(float(rng.uniform(0.7, 1.3)), float(rng.uniform(0.025, 0.06)), float(rng.uniform(-0.25, 0.2)),
                   float(rng.choice([-1.0, 1.0])), float(rng.uniform(0.15, 0.3)))


def _pose(move: str, beat: np.ndarray, phi: np.ndarray, bar_beats: int, st: Style
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotations ``(N, 24, 3)``, root offsets ``(N, 3)`` (lateral, up, forward) and rates
    ``(N, 3)`` (lateral and forward metres per beat, yaw radians per beat) of one move, at musical
    time ``beat`` (beats since the first downbeat) and ``phi`` (beats since the bar's downbeat)."""
    n = len(beat)
    rot = np.zeros((n, 24, 3))
    off = np.zeros((n, 3))
    rate = np.zeros((n, 3))
    a, s = st.amplitude, st.lead
    g = (1 + np.cos(2 * np.pi * beat)) / 2  # 1 on every beat, 0 half-way between
    # arms hang down (rotation about z), elbows slightly bent: the shared base pose
    rot[:, L_SHOULDER, 2], rot[:, R_SHOULDER, 2] = -1.2 - st.arms, 1.2 + st.arms
    rot[:, L_ELBOW, 1], rot[:, R_ELBOW, 1] = -0.3, 0.3
    swing = np.sin(np.pi * beat)  # +-1 over two beats, continuous across bars of any length
    if move == "bounce":
        rot[:, L_SHOULDER, 0] = -0.25 * a * swing
        rot[:, R_SHOULDER, 0] = 0.25 * a * swing
        rot[:, NECK, 0] = 0.1 * a * g
    elif move == "step-touch":
        off[:, 0] = 0.18 * a * s * np.sin(np.pi * beat / 2)
        rot[:, L_HIP, 2] = -0.12 * a * np.clip(np.sin(np.pi * beat / 2), 0, None)
        rot[:, R_HIP, 2] = 0.12 * a * np.clip(-np.sin(np.pi * beat / 2), 0, None)
        rot[:, L_ELBOW, 1] -= 0.6 * a * (1 - g)
        rot[:, R_ELBOW, 1] += 0.6 * a * (1 - g)
    elif move == "sway":
        roll = 0.12 * a * s * np.sin(np.pi * beat)
        rot[:, PELVIS, 2] = roll
        rot[:, SPINE1, 2] = -0.6 * roll
        rot[:, SPINE3, 2] = -0.4 * roll
        rot[:, L_SHOULDER, 2] += 0.5 + 0.3 * roll / 0.12
        rot[:, R_SHOULDER, 2] -= 0.5 - 0.3 * roll / 0.12
    elif move == "arm-wave":
        for k, (sh, el, wr, sign) in enumerate(((L_SHOULDER, L_ELBOW, L_WRIST, 1), (R_SHOULDER, R_ELBOW, R_WRIST, -1))):
            lag = np.pi * k * (s > 0)
            rot[:, sh, 2] = sign * (1.3 + 0.35 * a * np.sin(np.pi * beat + lag))
            rot[:, el, 2] = sign * 0.5 * a * np.sin(np.pi * beat + lag - 0.8)
            rot[:, wr, 2] = sign * 0.4 * a * np.sin(np.pi * beat + lag - 1.6)
    elif move == "clap":
        rot[:, L_SHOULDER] = np.stack([-1.0 * a + 0 * g, -0.5 - 0.5 * g, -1.0 + 0 * g], -1)
        rot[:, R_SHOULDER] = np.stack([-1.0 * a + 0 * g, 0.5 + 0.5 * g, 1.0 + 0 * g], -1)
        rot[:, L_ELBOW, 1], rot[:, R_ELBOW, 1] = -0.5 - 0.6 * g, 0.5 + 0.6 * g
    elif move == "spin":
        rate[:, 2] = s * np.pi * 4 / bar_beats * np.sin(np.pi * phi / bar_beats) ** 2  # 2 pi per bar
        rot[:, L_SHOULDER, 2], rot[:, R_SHOULDER, 2] = -0.5 * a, 0.5 * a
    elif move == "jump":
        off[:, 1] = 0.12 * a * np.sin(np.pi * beat) ** 2
        rot[:, L_SHOULDER, 2] = -1.2 + 0.9 * a * np.sin(np.pi * beat) ** 2
        rot[:, R_SHOULDER, 2] = 1.2 - 0.9 * a * np.sin(np.pi * beat) ** 2
    elif move == "kick":
        left = np.clip(np.sin(np.pi * beat), 0, None) ** 2
        right = np.clip(-np.sin(np.pi * beat), 0, None) ** 2
        rot[:, L_HIP, 0], rot[:, R_HIP, 0] = -0.9 * a * left, -0.9 * a * right
        rot[:, L_SHOULDER, 0], rot[:, R_SHOULDER, 0] = 0.3 * a * left, 0.3 * a * right
    elif move == "walk":
        rate[:, 1] = st.speed
        rate[:, 2] = s * np.pi / 4
        rot[:, L_HIP, 0], rot[:, R_HIP, 0] = -0.35 * a * swing, 0.35 * a * swing
        rot[:, L_KNEE, 0] = 0.5 * a * np.clip(swing, 0, None)
        rot[:, R_KNEE, 0] = 0.5 * a * np.clip(-swing, 0, None)
        rot[:, L_SHOULDER, 0], rot[:, R_SHOULDER, 0] = 0.3 * a * swing, -0.3 * a * swing
    # the groove: a knee bend and hip dip on every beat, whatever the move
    bend = np.arccos(1 - st.groove * g / (2 * THIGH))
    for hip, knee, ankle in ((L_HIP, L_KNEE, L_ANKLE), (R_HIP, R_KNEE, R_ANKLE)):
        rot[:, hip, 0] -= bend
        rot[:, knee, 0] += 2 * bend
        rot[:, ankle, 0] -= bend
    off[:, 1] -= st.groove * g
    return rot, off, rate


def all_texts() -> list[str]:
    """Every text the synthetic dancer labels motion with: all phrasings of all moves, in table order
    (what a vocabulary for the synthetic corpora must cover, e.g. ``Vocabulary.build(all_texts())``)."""
    return list(dict.fromkeys(t for move in NAMES for t in PHRASINGS[move]))


def choose_moves(sections: list[tuple[str, int, int]], rng: np.random.Generator) -> list[int]:
    """A move per bar: phrases of one or two bars drawn with the section's preferences."""
    moves: list[int] = []
    for name, first, end in sections:
        w = np.asarray(SECTION_WEIGHTS.get(name, SECTION_WEIGHTS["verse"]), float)
        bar = first
        while bar < end:
            m = int(rng.choice(len(NAMES), p=w / w.sum()))
            length = int(rng.choice([1, 2, 2]))
            moves += [m] * min(length, end - bar)
            bar += length
    return moves


def dance(grid: BeatGrid, bar_moves: list[int], seconds: float, fps: float,
          style: Style) -> tuple[Motion, tuple[TextSpan, ...]]:
    """The dance to the beats of ``grid``: ``bar_moves[k]`` is the move of bar ``k`` (bars from
    the first downbeat; the pickup before it dances the first bar's move)."""
    n = frame_count(seconds, fps)
    bpb = grid.beats_per_bar
    beat = grid.beat_at(np.arange(n) / fps)
    bar = np.clip(np.floor(beat / bpb).astype(int), 0, len(bar_moves) - 1)
    phi = beat - bpb * np.floor(beat / bpb)
    moves = np.asarray(bar_moves)[bar]
    nxt = np.asarray(bar_moves)[np.minimum(bar + 1, len(bar_moves) - 1)]
    blend = np.clip((phi - (bpb - 0.5)) / 0.5, 0, 1) * (beat >= 0)  # no change before bar 0
    blend = blend * blend * (3 - 2 * blend)  # smoothstep into the next bar's move
    weights = np.zeros((n, len(NAMES)))
    np.add.at(weights, (np.arange(n), moves), 1 - blend)
    np.add.at(weights, (np.arange(n), nxt), blend)
    rot = np.zeros((n, 24, 3))
    off = np.zeros((n, 3))
    rate = np.zeros((n, 3))
    for m in np.flatnonzero(weights.sum(0) > 0):
        r, o, v = _pose(NAMES[m], beat, phi, bpb, style)
        w = weights[:, m]
        rot += w[:, None, None] * r
        off += w[:, None] * o
        rate += w[:, None] * v
    d_beat = np.diff(beat, prepend=2 * beat[0] - beat[1] if n > 1 else beat[0])  # beats per frame
    yaw = np.cumsum(rate[:, 2] * d_beat)
    h = yaw_quat(yaw)
    step = quat_rotate(h, np.stack([rate[:, 0], np.zeros(n), rate[:, 1]], -1)) * d_beat[:, None]
    ground = np.cumsum(step, axis=0)
    root = ground + quat_rotate(h, off * np.array([1.0, 0.0, 1.0])) + np.array([0.0, STAND, 0.0])
    root[:, 1] += off[:, 1]
    quats = expmap_to_quat(rot)
    quats[:, 0] = quat_mul(h, quats[:, 0])
    motion = Motion(smpl24(), fps, root, quats)
    texts = []
    start_bar = 0
    for b in range(1, len(bar_moves) + 1):
        if b == len(bar_moves) or bar_moves[b] != bar_moves[start_bar]:
            t0 = 0.0 if start_bar == 0 else max(0.0, float(grid.time_of(start_bar * bpb)))
            t1 = seconds if b == len(bar_moves) else min(seconds, float(grid.time_of(b * bpb)))
            if t1 > t0:
                texts.append(TextSpan(MOVES[NAMES[bar_moves[start_bar]]], round(t0, 4), round(t1, 4)))
            start_bar = b
    return motion, tuple(texts)
