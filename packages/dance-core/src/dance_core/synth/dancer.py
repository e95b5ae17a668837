"""A beat-locked dancer on ``dance24`` (SMPL-24 joints): moves chosen per bar, with timed text labels.

Every move is a pose function of musical time (a :class:`~dance_core.synth.beat_grid.BeatGrid`:
beats since the first downbeat, on even or uneven beats, in bars of 2-7 beats): joint rotations as
exponential maps, periodic root offsets and root rates (travel, turning, per beat) that are
integrated over time. A groove shared by all moves dips the hips on every beat, so the hip's
height minima (its zero vertical velocity at the bottom) sit on the music's beats. Moves change at
bar lines with half a beat of blending; which move comes when depends on the section and a seed,
so one song admits many dances. :data:`PHRASINGS` words each move several ways (the captions of the
``synthetic-moves`` text-motion clips); :func:`all_texts` lists every text the dancer can produce.

That is the ``classic`` dancer. :data:`DANCERS` adds five profiles (:class:`Dancer`), each with its
own moves, a Markov chain over them (three or four successors each), phrases of a drawn number of
beats that ignore the bar lines (so a phrase may change at any beat, at most once a bar), a drawn
side per phrase, style ranges and timing: on or off the beat (``Style.delay``), smooth or sharp
(``Style.attack``, a warp of the dancer's time within each beat). What a dancer does next is then
not given by the last two seconds: when the phrase ends, which of the successors follows and to
which side. :meth:`Dancer.routine` is the opposite, the fixed routine of the homogeneous control.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dance_core.media import TextSpan, frame_count
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat, quat_mul, quat_rotate, yaw_quat
from dance_core.motion.skeletons import dance24
from dance_core.synth.beat_grid import BeatGrid

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
_REST = dance24().rest_positions()
#: root height when standing: dance24's rest pose stands on the floor (its toe tips at y = 0; the ball
#: joints 2 cm up, the sole below them)
STAND = float(_REST[0, 1])
THIGH = float(np.linalg.norm(_REST[4] - _REST[1]))


@dataclass
class Style:
    """Per-dance variation: amplitude, groove depth, arm carriage, lead side, speed, and timing:
    ``delay`` (beats the dancer's accents fall after the music's: 0.5 dances off the beat) and
    ``attack`` (0: smooth; up to 0.75: slow out of each accent, fast into the next, a sharp hit)."""

    amplitude: float
    groove: float
    arms: float
    lead: float
    speed: float
    delay: float = 0.0
    attack: float = 0.0

    @classmethod
    def draw(cls, rng: np.random.Generator) -> Style:
        """A random style of the classic dancer (:data:`DANCERS` ``["classic"]``)."""
        return DANCERS[CLASSIC].draw_style(rng)


def _pose(move: str, beat: np.ndarray, phi: np.ndarray, bar_beats: int, st: Style
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotations ``(N, 24, 3)``, root offsets ``(N, 3)`` (lateral, up, forward) and rates
    ``(N, 3)`` (lateral and forward metres per beat, yaw radians per beat) of one move, at musical
    time ``beat`` (beats since the first downbeat) and ``phi`` (beats since the bar's downbeat)."""
    if np.any(st.delay) or np.any(st.attack):
        beat, phi = dancer_time(beat, phi, st)
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


def dancer_time(beat: np.ndarray, phi: np.ndarray, st: Style) -> tuple[np.ndarray, np.ndarray]:
    """The dancer's own musical time: the music's ``beat`` and bar phase ``phi`` delayed by
    ``st.delay`` beats and warped within each beat by ``st.attack`` (the warp keeps whole beats in
    place, so every move still hits its accents on the dancer's beats, but arrives at them faster than
    it leaves them)."""
    u = beat - st.delay
    # the dancer's time runs at 1 - attack * (sin 2 pi u + sin 4 pi u / 2) beats per beat: slowest a
    # sixth of a beat after each beat, fastest a sixth before; two harmonics, so that played backwards
    # it is not the same warp shifted in time (one sine would be)
    warp = -st.attack * ((1 - np.cos(2 * np.pi * u)) / (2 * np.pi) + (1 - np.cos(4 * np.pi * u)) / (8 * np.pi))
    return u + warp, phi - st.delay + warp


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


@dataclass(frozen=True)
class Dancer:
    """A dancer profile: its moves and what may follow each (``chain``: move -> successors with weights,
    a Markov chain over moves; ``None``: every move, one or two bars each, as :func:`choose_moves`),
    its phrase lengths in beats (drawn uniformly, at least ``bar - 1`` beats, so a bar holds at most
    one change), the chance ``mirror`` that a phrase leads with the other side, the ranges of its
    style and its timing (``delay``, ``attack``: see :class:`Style`)."""

    chain: dict[str, dict[str, float]] | None
    phrases: tuple[int, ...]
    amplitude: tuple[float, float]
    groove: tuple[float, float]
    arms: tuple[float, float]
    speed: tuple[float, float] = (0.15, 0.3)
    delay: float = 0.0
    attack: float = 0.0
    mirror: float = 0.5

    @property
    def moves(self) -> list[str]:
        """The moves this dancer dances, in table order."""
        return [m for m in NAMES if self.chain is None or m in self.chain]

    def draw_style(self, rng: np.random.Generator) -> Style:
        """A random style within the profile's ranges (either lead side)."""
        return Style(float(rng.uniform(*self.amplitude)), float(rng.uniform(*self.groove)),
                     float(rng.uniform(*self.arms)), float(rng.choice([-1.0, 1.0])), float(rng.uniform(*self.speed)),
                     self.delay, self.attack)

    def style(self) -> Style:
        """The profile's one central style (the middle of every range, leading with the right)."""
        mid = lambda r: (r[0] + r[1]) / 2  # noqa: E731
        return Style(mid(self.amplitude), mid(self.groove), mid(self.arms), 1.0, mid(self.speed), self.delay,
                     self.attack)

    def phrase_moves(self, sections: list[tuple[str, int, int]], bar_beats: int,
                     rng: np.random.Generator) -> list[tuple[int, int, int]]:
        """Phrases ``(first beat, move, side)``: each move drawn from the chain's successors of the last,
        weighted by the section's preference (``1 + SECTION_WEIGHTS``), for a drawn number of beats
        that ignores the bar lines, on a drawn side; a section starts a new phrase."""
        assert self.chain is not None, "the classic dancer chooses its moves per bar (choose_moves)"
        phrases: list[tuple[int, int, int]] = []
        move = None
        for name, first, end in sections:
            prefer = SECTION_WEIGHTS.get(name, SECTION_WEIGHTS["verse"])
            beat = first * bar_beats
            while beat < end * bar_beats:
                options = self.chain[move] if move else dict.fromkeys(self.chain, 1.0)
                w = np.asarray([p * (1 + prefer[NAMES.index(m)]) for m, p in options.items()])
                move = list(options)[int(rng.choice(len(w), p=w / w.sum()))]
                phrases.append((beat, NAMES.index(move), -1 if rng.random() < self.mirror else 1))
                beat += max(int(rng.choice(self.phrases)), bar_beats - 1)
        return phrases

    def routine(self, sections: list[tuple[str, int, int]], bar_beats: int) -> list[tuple[int, int, int]]:
        """The fixed routine of the homogeneous control: in every section the profile's three moves that
        section prefers most (``SECTION_WEIGHTS``, ties in table order), in turn, one bar each."""
        phrases = []
        for name, first, end in sections:
            prefer = SECTION_WEIGHTS.get(name, SECTION_WEIGHTS["verse"])
            top = sorted(self.moves, key=lambda m: -prefer[NAMES.index(m)])[:3]
            phrases += [(bar * bar_beats, NAMES.index(top[(bar - first) % len(top)]), 1) for bar in range(first, end)]
        return phrases


CLASSIC = "classic"
#: the dancers of the synthetic choreography: ``classic`` (every move, chosen per bar; the only one before
#: dancer profiles, and the default) and five profiles with their own moves, Markov chains (every move
#: has three or four successors, itself on the other side among them for some), phrasing, amplitudes
#: and timing
DANCERS = {
    CLASSIC: Dancer(None, (), (0.7, 1.3), (0.025, 0.06), (-0.25, 0.2), mirror=0.0),
    "bouncer": Dancer(  # small and busy, on the beat
        {"bounce": {"clap": 2, "step-touch": 2, "jump": 1, "kick": 1},
         "clap": {"bounce": 2, "kick": 1, "jump": 1, "step-touch": 1},
         "step-touch": {"step-touch": 2, "bounce": 1, "clap": 2, "kick": 1},
         "jump": {"bounce": 2, "clap": 1, "step-touch": 1, "kick": 1},
         "kick": {"kick": 1, "step-touch": 2, "bounce": 1, "jump": 1}},
        (3, 4, 5), (0.75, 0.95), (0.045, 0.06), (-0.1, 0.1)),
    "glider": Dancer(  # large and smooth, long phrases, off the beat
        {"sway": {"sway": 1, "arm-wave": 2, "walk": 1, "step-touch": 1},
         "arm-wave": {"arm-wave": 1, "sway": 2, "walk": 1, "spin": 1},
         "walk": {"sway": 1, "arm-wave": 1, "spin": 1},
         "spin": {"sway": 1, "walk": 1, "arm-wave": 1},
         "step-touch": {"sway": 2, "arm-wave": 1, "walk": 1}},
        (4, 6, 8), (0.95, 1.25), (0.025, 0.035), (-0.25, -0.1), (0.2, 0.3), delay=0.5),
    "hitter": Dancer(  # large and sharp, on the beat
        {"jump": {"kick": 2, "clap": 1, "spin": 1, "jump": 1},
         "kick": {"jump": 2, "clap": 1, "arm-wave": 1, "kick": 1},
         "clap": {"jump": 1, "kick": 1, "spin": 1},
         "spin": {"clap": 1, "jump": 1, "arm-wave": 1, "spin": 1},
         "arm-wave": {"kick": 1, "clap": 2, "spin": 1}},
        (3, 4), (1.1, 1.35), (0.04, 0.06), (0.0, 0.2), attack=0.6),
    "popper": Dancer(  # small and sharp, off the beat
        {"clap": {"bounce": 1, "kick": 1, "arm-wave": 1, "sway": 1},
         "bounce": {"clap": 2, "sway": 1, "kick": 1},
         "kick": {"clap": 1, "bounce": 1, "sway": 1, "kick": 1},
         "arm-wave": {"sway": 1, "clap": 1, "kick": 1, "arm-wave": 1},
         "sway": {"arm-wave": 1, "bounce": 1, "kick": 1, "sway": 1}},
        (3, 4, 6), (0.7, 0.9), (0.03, 0.045), (-0.05, 0.15), delay=0.5, attack=0.6),
    "wanderer": Dancer(  # travels and turns, on the beat, a little sharp
        {"walk": {"walk": 1, "spin": 1, "step-touch": 1, "sway": 1},
         "spin": {"walk": 2, "bounce": 1, "spin": 1},
         "step-touch": {"walk": 1, "sway": 1, "spin": 1, "step-touch": 1},
         "sway": {"step-touch": 1, "walk": 1, "bounce": 1},
         "bounce": {"walk": 1, "step-touch": 1, "spin": 1}},
        (4, 6, 8), (0.8, 1.05), (0.03, 0.05), (-0.15, 0.05), (0.22, 0.3), attack=0.3),
}


def dancer_names(names: list[str] | None) -> list[str]:
    """The dancers named (``None``: all of :data:`DANCERS`); a ``ValueError`` names unknown ones."""
    if names is None:
        return list(DANCERS)
    unknown = [n for n in names if n not in DANCERS]
    if unknown or not names:
        raise ValueError(f"unknown dancer(s) {', '.join(unknown) or '(none given)'}; known: {', '.join(DANCERS)}")
    return list(names)


def perform_dance(dancer: str, grid: BeatGrid, sections: list[tuple[str, int, int]], seconds: float, fps: float,
                  rng: np.random.Generator, homogeneous: bool = False) -> tuple[Motion, tuple[TextSpan, ...]]:
    """One dance of ``dancer`` to ``grid``'s beats in ``sections`` (name, first bar, end bar), drawn from
    ``rng``; ``homogeneous``: the profile's central style and fixed :meth:`Dancer.routine` (no draws)."""
    profile = DANCERS[dancer]
    bar_beats = grid.beats_per_bar
    if homogeneous:
        return dance_phrases(grid, profile.routine(sections, bar_beats), seconds, fps, profile.style())
    if profile.chain is None:
        moves = choose_moves(sections, rng)
        moves += moves[-1:] * max(0, grid.bars(seconds) - len(moves))
        return dance(grid, moves, seconds, fps, Style.draw(rng))
    style = profile.draw_style(rng)
    return dance_phrases(grid, profile.phrase_moves(sections, bar_beats, rng), seconds, fps, style)


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
    motion = render_moves(beat, phi, bpb, moves, nxt, blend, fps, style)
    changes = [(b * bpb, m) for b, m in enumerate(bar_moves) if b == 0 or m != bar_moves[b - 1]]
    return motion, _spans(grid, changes, seconds)


def dance_phrases(grid: BeatGrid, phrases: list[tuple[int, int, int]], seconds: float, fps: float,
                  style: Style) -> tuple[Motion, tuple[TextSpan, ...]]:
    """The dance to the beats of ``grid`` in phrases ``(first beat, move, side)`` of any length (beats
    from the first downbeat, increasing; the first phrase also dances the pickup, the last one to the
    end; side -1 leads with the other side than the style): each phrase blends into the next over the
    half beat before it starts."""
    n = frame_count(seconds, fps)
    bpb = grid.beats_per_bar
    beat = grid.beat_at(np.arange(n) / fps)
    phi = beat - bpb * np.floor(beat / bpb)
    starts = np.asarray([b for b, _, _ in phrases] + [np.inf], float)
    column = [m + len(NAMES) * (side < 0) for _, m, side in phrases]
    column = np.asarray(column + column[-1:])
    k = np.clip(np.searchsorted(starts, beat, side="right") - 1, 0, len(phrases) - 1)
    blend = np.clip((beat - (starts[k + 1] - 0.5)) / 0.5, 0, 1)
    blend = blend * blend * (3 - 2 * blend)
    motion = render_moves(beat, phi, bpb, column[k], column[k + 1], blend, fps, style)
    changes = [(b, m) for i, (b, m, _) in enumerate(phrases) if i == 0 or m != phrases[i - 1][1]]
    return motion, _spans(grid, changes, seconds)


def render_moves(beat: np.ndarray, phi: np.ndarray, bpb: int, moves: np.ndarray, nxt: np.ndarray, blend: np.ndarray,
            fps: float, style: Style) -> Motion:
    """The motion at musical times ``beat`` (bar phase ``phi``): per frame the move ``moves`` blended
    by ``blend`` (0-1) into ``nxt`` (indices into ``NAMES``; plus ``len(NAMES)``: led with the other side);
    root travel and turning integrated over the beats. The style's fields may be arrays of one value
    per frame: many styles rendered at once (where ``beat`` jumps, the root jumps with it)."""
    n = len(beat)
    weights = np.zeros((n, 2 * len(NAMES)))
    np.add.at(weights, (np.arange(n), moves), 1 - blend)
    np.add.at(weights, (np.arange(n), nxt), blend)
    rot = np.zeros((n, 24, 3))
    off = np.zeros((n, 3))
    rate = np.zeros((n, 3))
    for m in np.flatnonzero(weights.sum(0) > 0):
        side = style if m < len(NAMES) else replace(style, lead=-style.lead)
        r, o, v = _pose(NAMES[m % len(NAMES)], beat, phi, bpb, side)
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
    return Motion(dance24(), fps, root, quats)


def _spans(grid: BeatGrid, changes: list[tuple[int, int]], seconds: float) -> tuple[TextSpan, ...]:
    """Text labels of a dance whose move changes to ``move`` at each ``(beat, move)`` of ``changes``
    (the first from the start): one span per change, up to the next or the end."""
    spans = []
    for i, (b, m) in enumerate(changes):
        t0 = 0.0 if i == 0 else max(0.0, float(grid.time_of(b)))
        t1 = seconds if i == len(changes) - 1 else min(seconds, float(grid.time_of(changes[i + 1][0])))
        if t1 > t0:
            spans.append(TextSpan(MOVES[NAMES[m]], round(t0, 4), round(t1, 4)))
    return tuple(spans)
