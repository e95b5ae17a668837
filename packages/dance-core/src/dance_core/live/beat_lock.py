"""Beat locking live: the dance's own accents moved onto the music's beats as it plays, causally.

Offline, ``compose.beat_align`` (:mod:`dance_core.motion.beat_align`) warps the whole dance's time so
its accents land on beats. Live, the same warp is run forward, one output frame at a time:

* **beats** (:class:`BeatClock`): the beat tracker's phase columns (sin and cos of the beat phase, as
  the ``beats`` extractor gives them live) give each beat's time to within a tracker frame, and the
  tempo (the phase's advance per frame), so beats ahead are predicted. Where the tracker also places
  beats with hindsight (``settled_beats``: dance-audio's Viterbi decoding of all heard, traced back every
  0.25 s), those are used instead: the dance plays over a second behind the music heard, so the beats it
  is steered to have been heard with a second or more after them, which the phase (the forward pass)
  cannot use. The tracker has heard the music ``music_delay`` (0.556 s for the bundled model) past the
  frame being generated, so the next beat or two are known, not guessed. What the tracker says reaches the
  clock through :class:`BeatFeed`, up to the music the frame being posed waited for and no further, so the
  dance does not depend on how far the audio has run ahead of the model;
* **accents** (:class:`LiveAccents`): the body's pauses (:func:`dance_core.motion.body.energy_minima`
  on :func:`~dance_core.motion.body.body_energy`, the rule offline alignment and the metrics use) over
  the last ``WINDOW`` (20) s of generated frames, each known ``SETTLE`` frames after it;
* **the warp** (:class:`BeatLock`): output frame ``j`` (music time ``j / fps``) shows the generated
  dance at a source frame ``s <= j``, ``s`` advancing by a rate within ``[1 / max_rate, max_rate]`` (:data:`MAX_RATE`).
  The dance plays ``LAG`` seconds behind the frames generated (it starts by holding its first pose
  that long), so accents are seen before they are played: the next accent is steered onto a beat it can
  reach within the rate bounds, the one that brings the lag nearest ``LAG`` (else the beat nearest
  where it would land, within ``REACH`` of a period), re-planned every frame; with no accent to steer,
  the lag drifts back to ``LAG``. The rate moves gently where the body's energy is steady
  (:data:`RATE_FLOOR`) and freely where it is changing (:data:`RATE_GAIN`): the played dance's energy is about
  the rate times the generated one's, so a rate change in a steady stretch makes a pause of its own or moves
  one, where a change of pace hides it. Poses between frames: root linear, rotations slerped, as offline.

The price: the dance shows what the model made about ``LAG`` (at most ``MAX_LAG``) earlier, so its
reaction to the music comes that much after the frame's own latency (``lag_s`` in the summary).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from dance_core.motion.body import Body, body_energy, energy_minima
from dance_core.motion.fk import joint_positions
from dance_core.motion.rotations import quat_slerp
from dance_core.motion.skeleton import Skeleton

#: the most the dance is sped up or slowed down. Offline's bound is 1.35; live, each accent is steered only once
#: the one before it has played, so about half of them cannot reach a beat at 1.35. With the rate eased where the
#: body moves steadily (RATE_FLOOR), simulated over 42 dances (seven songs x seeds 0-5 x 60 s; body locking against
#: offline's 0.457; the live dance's mean jerk / offline's; the 99th percentile of its per-frame jerk, m/s^3; frames
#: played faster than 2x): 1.7: 0.391, 0.97x, 394, 0 %; 2.0: 0.409, 0.98x, 386, 0 %; 2.3: 0.416, 0.99x, 397,
#: 0.5 %; 2.6: 0.420, 1.00x, 422, 0.7 %; 3.0: 0.417, 1.01x, 430, 0.8 %; skating, speed and the realism distance the
#: same at each. 2.3: the most locking before the jerk's tail grows (chosen on seeds 0-2: 0.401 against 1.7's
#: 0.384; seeds 3-5 0.430 against 0.398). Without the easing, at 1.7: 0.371, 1.04x, 460
MAX_RATE = 2.3
#: an accent is steered to a beat within this share of a beat period of where it would land
REACH = 0.45
#: seconds the dance plays behind the generated frames, and the most it may (on the four fixture songs,
#: simulated: 0.75 and 1.2 s gave a body locking of 0.26 on average, 1.0 and 1.6 s 0.34, better on each
#: song; 1.25 and 2.0 s 0.33, with controls rising to 0.31)
LAG, MAX_LAG = 1.0, 1.6
#: seconds of generated frames the accents are found in (below their median energy, as offline over the song;
#: over 42 simulated dances 6 s found 2,396 accents, 20 s 1,832, the whole dance's median 1,935)
WINDOW = 20.0
#: frames after an accent before it counts (its energy's smoothing and neighbours)
SETTLE = 5
#: the most the log of the rate changes from one output frame to the next: RATE_FLOOR, or RATE_GAIN times the
#: change in the log of the body's energy over the source frames just played, where that is more. Simulated
#: (seven songs x seeds 0-5 x 60 s, 42 dances, paired against the unlimited rate with WINDOW 6 and SETTLE 3):
#: locking 0.391 against 0.371 (offline's 0.457; +0.020, standard error 0.014), jerk 0.97x offline's against
#: 1.04x (seeds 0-2: +0.039, standard error 0.019; seeds 3-5: +0.002, 0.019); a gain of 2: +0.003, 8: +0.013;
#: the window and settling alone: +0.006
RATE_FLOOR, RATE_GAIN = 0.05, 4.0
#: settled beats needed before they replace the phase's, and the last ones whose median interval is the tempo
SETTLED_MIN, SETTLED_TEMPO = 4, 8


class BeatClock:
    """Beat times from the tracker's phase columns, frame by frame: ``update(frame, sin, cos)``, or from the
    beats it placed with hindsight, ``settle(times)``, once it has placed :data:`SETTLED_MIN`; ``ahead(t)``
    the beats after ``t`` (known, then predicted at the current tempo)."""

    def __init__(self, fps: float):
        self.fps = float(fps)
        self.phase: float | None = None
        self.periods: deque[float] = deque(maxlen=8)
        self.beats: deque[float] = deque(maxlen=16)
        self.settled = np.zeros(0)

    @property
    def period(self) -> float | None:
        """The current beat period (s), None before the tempo is known."""
        if len(self.settled) >= SETTLED_MIN:
            return float(np.median(np.diff(self.settled[-SETTLED_TEMPO:])))
        return float(np.median(self.periods)) if self.periods else None

    def settle(self, times: np.ndarray) -> None:
        """The tracker's latest beats placed with hindsight (s, ascending): they replace the phase's beats
        once there are :data:`SETTLED_MIN` of them."""
        self.settled = np.asarray(times, np.float64)

    def update(self, frame: int, sin: float, cos: float) -> None:
        """The beat phase at music frame ``frame``."""
        phase = float(np.arctan2(sin, cos) / (2 * np.pi)) % 1.0
        if self.phase is not None:
            step = (phase - self.phase) % 1.0
            if 1e-3 < step < 0.5:
                self.periods.append(1.0 / self.fps / step)
            if phase < self.phase - 0.5 and self.period is not None:  # the phase wrapped: a beat
                self.beats.append(frame / self.fps - phase * self.period)
        self.phase = phase

    def ahead(self, t: float, horizon: float) -> np.ndarray:
        """Beat times (s) after ``t`` up to ``t + horizon``: those heard, then predicted at the current tempo."""
        period = self.period
        heard = self.settled if len(self.settled) >= SETTLED_MIN else np.array(self.beats)
        if period is None or not len(heard):
            return np.zeros(0)
        known = heard[heard > t]
        last = heard[-1]
        extra = last + period * np.arange(1, int(np.ceil((t + horizon - last) / period)) + 1)
        out = np.concatenate([known, extra[extra > t]])
        return out[out <= t + horizon]


class BeatFeed:
    """The tracker's output held back until the frame it may inform: ``add(rows, traces)`` as the audio arrives
    (phase rows, one per music frame; settled beats as ``(seconds heard, beats)``), ``advance(newest)`` before a
    frame is posed gives the clock the rows of music frames up to ``newest`` and the settled beats placed with
    the music to ``newest / fps`` (a trace whose time is unknown, None, at once). The frame waited for the music
    to ``newest``, so all of that has arrived, and the clock sees the same however the audio was split into
    blocks or how far it ran ahead of the model: the same song gives the same dance."""

    def __init__(self, clock: BeatClock):
        self.clock = clock
        self.rows: deque[tuple[int, float, float]] = deque()
        self.traces: deque[tuple[float | None, np.ndarray]] = deque()
        self.frames = 0  # rows received

    def add(self, rows: np.ndarray, traces: list[tuple[float | None, np.ndarray]]) -> None:
        """The tracker's new rows (sin and cos of the beat phase in columns 2 and 3) and settled beats."""
        for row in rows:
            self.rows.append((self.frames, float(row[2]), float(row[3])))
            self.frames += 1
        self.traces.extend(traces)

    def advance(self, newest: int) -> None:
        """Give the clock what the music up to frame ``newest`` told."""
        while self.rows and self.rows[0][0] <= newest:
            self.clock.update(*self.rows.popleft())
        latest = None
        while self.traces and (self.traces[0][0] is None or self.traces[0][0] <= newest / self.clock.fps + 1e-9):
            latest = self.traces.popleft()
        if latest is not None:
            self.clock.settle(latest[1])


class LiveAccents:
    """The body's accents in generated frames as they come: ``push(frame, positions)`` gives the source frames
    (float) of accents newly settled."""

    def __init__(self, skeleton: Skeleton, fps: float):
        self.fps = float(fps)
        self.body = Body.of(skeleton.names, "live dance")
        self.buffer: deque[np.ndarray] = deque(maxlen=int(round(WINDOW * self.fps)))
        self.frame = -1  # the newest frame pushed
        self.last = -np.inf  # the newest accent given
        self.count = 0
        self.energy, self.first = np.zeros(0), 0  # the body's energy over the buffer, and its first frame

    def push(self, frame: int, positions: np.ndarray) -> list[float]:
        """Take generated frame ``frame``'s joint positions ``(J, 3)``; the accents settled since the last call."""
        self.buffer.append(np.asarray(positions, np.float64))
        self.frame = frame
        if len(self.buffer) < 2 * SETTLE + 3:
            return []
        energy = body_energy(np.stack(self.buffer), self.fps, self.body, 1.0)
        first = frame - len(self.buffer) + 1
        self.energy, self.first = energy, first
        found = [first + float(i) for i in energy_minima(energy, self.fps) if i <= len(energy) - 1 - SETTLE]
        order = max(1, int(round(0.2 * self.fps / 2)))
        new = [a for a in found if a > self.last + order]
        if new:
            self.last = new[-1]
            self.count += len(new)
        return new

    def energy_at(self, source: float) -> float | None:
        """The body's energy (per unit leg) at fractional generated frame ``source`` (held past the buffer's
        ends); None before accents are looked for."""
        if not len(self.energy):
            return None
        k = float(np.clip(source - self.first, 0, len(self.energy) - 1))
        lo = int(k)
        hi = min(lo + 1, len(self.energy) - 1)
        return float((1 - (k - lo)) * self.energy[lo] + (k - lo) * self.energy[hi])


class BeatLock:
    """Generated poses in, beat-locked poses out: ``push(frame, root, rotations, positions)`` for each
    generated frame (skipped frames hold the last), then ``pose(frame)`` for the output frame of the same
    index: ``(root, rotations, positions)`` of the dance at its source frame (``source``, ``lag``)."""

    def __init__(self, skeleton: Skeleton, fps: float, clock: BeatClock, max_rate: float = MAX_RATE):
        self.skeleton, self.fps, self.clock, self.max_rate = skeleton, float(fps), clock, float(max_rate)
        self.accents = LiveAccents(skeleton, fps)
        self.planned: deque[float] = deque()  # accents (source frames) not yet played
        self.poses: deque[tuple] = deque(maxlen=int(round((MAX_LAG + 1.0) * self.fps)))
        self.newest = -1
        self.source = -LAG * self.fps  # the first pose is held while the lag builds
        self.output = -1
        self.rate = 1.0
        self.lags: list[float] = []

    def push(self, frame: int, root: np.ndarray, rotations: np.ndarray | None, positions: np.ndarray) -> None:
        """Generated frame ``frame``'s pose (a gap after the last one is filled with the last pose, held)."""
        while self.newest >= 0 and self.newest + 1 < frame:
            self.poses.append(self.poses[-1])
            self.newest += 1
            self.planned.extend(self.accents.push(self.newest, self.poses[-1][2]))  # the hold, frame by frame
        self.poses.append((np.asarray(root, np.float64), rotations, np.asarray(positions, np.float64)))
        self.newest = frame
        self.planned.extend(self.accents.push(frame, positions))

    def pose(self, frame: int) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """The output pose for music frame ``frame`` (at most the newest generated frame)."""
        steps = frame - self.output  # a first call after frames held elsewhere catches up
        for _ in range(max(1, steps)):
            self._advance()
        self.output = frame
        self.lags.append((frame - max(self.source, 0.0)) / self.fps)
        return self._sample(max(self.source, 0.0))

    def _advance(self) -> None:
        """Move the source on by one output frame's rate."""
        j = self.output + 1
        while self.planned and self.planned[0] <= self.source:
            self.planned.popleft()
        target = self._plan(j) if self.source >= 0 else None
        if target is None:  # nothing to steer: drift back to the nominal lag
            lag = j - 1 - self.source
            target = float(np.clip(1.0 + (lag - LAG * self.fps) / (2 * self.fps), 1 / 1.1, 1.1))
        if self.source >= 0:
            step = self._rate_step()
            target = float(np.clip(target, self.rate * np.exp(-step), self.rate * np.exp(step)))
        self.rate = target
        self.output = j
        self.source = min(self.source + self.rate, float(j), float(self.newest))
        self.source = max(self.source, j - MAX_LAG * self.fps)

    def _rate_step(self) -> float:
        """How far the log of the rate may move this frame: :data:`RATE_FLOOR`, more where the body's energy
        changed over the source frames just played (:data:`RATE_GAIN` times its log's change)."""
        now, before = self.accents.energy_at(self.source), self.accents.energy_at(self.source - self.rate)
        if now is None or before is None:
            return RATE_FLOOR
        change = abs(np.log(max(now, 1e-6)) - np.log(max(before, 1e-6)))
        return max(RATE_FLOOR, RATE_GAIN * change)

    def _plan(self, j: int) -> float | None:
        """The rate that lands the next accent on a beat: of the beats reachable within the rate bounds, the
        one nearest where the accent would land with the lag at ``LAG`` (so steering keeps the lag that lets
        accents be seen ahead), else the one nearest where it would land at rate 1 (the rate clipped)."""
        if not self.planned or self.clock.period is None:
            return None
        accent = self.planned[0]
        ahead = accent - self.source  # source frames until the accent plays
        now = (j - 1) / self.fps
        beats = self.clock.ahead(now, ahead * self.max_rate / self.fps + self.clock.period)
        frames = beats * self.fps - (j - 1)
        beats, frames = beats[frames > 0], frames[frames > 0]
        if not len(beats):
            return None
        rates = ahead / frames
        reachable = (rates >= 1 / self.max_rate) & (rates <= self.max_rate)
        if reachable.any():
            ideal = (accent + LAG * self.fps) / self.fps
            pick = np.flatnonzero(reachable)[np.argmin(np.abs(beats[reachable] - ideal))]
        else:
            pick = int(np.argmin(np.abs(beats - (now + ahead / self.fps))))
            if abs(beats[pick] - now - ahead / self.fps) > REACH * self.clock.period:
                return None
        return float(np.clip(rates[pick], 1 / self.max_rate, self.max_rate))

    def _sample(self, source: float) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """The pose at fractional source frame ``source``: root and positions linear, rotations slerped."""
        first = self.newest - len(self.poses) + 1
        k = float(np.clip(source - first, 0, len(self.poses) - 1))
        lo = int(np.floor(k))
        hi, w = min(lo + 1, len(self.poses) - 1), k - lo
        a, b = self.poses[lo], self.poses[hi]
        if w < 1e-9 or hi == lo:
            return a
        root = (1 - w) * a[0] + w * b[0]
        if a[1] is None:
            return root, None, (1 - w) * a[2] + w * b[2]
        rotations = quat_slerp(a[1], b[1], np.full((len(a[1]), 1), w))
        return root, rotations, joint_positions(self.skeleton, root, rotations)
