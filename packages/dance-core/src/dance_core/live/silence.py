"""When the music stops, the figure comes to rest: silence found in the audio as it arrives, and how much the
figure rests at each frame.

A music frame ``i`` (the audio from ``i / fps`` to ``(i + 1) / fps``) is **silent** when its level (RMS, dB
full scale) is below ``floor`` dBFS (:data:`FLOOR_DB`, ``dance live --silence``) or more than :data:`RANGE_DB`
below the loudest second heard so far (so a quiet recording's pauses count, and its music does not). The
figure **rests** at frame ``i`` when the frames from :data:`HOLD` s before it to :data:`AHEAD` s after it are
all silent: a breath between phrases does not stop the dance, a pause of a second or more does, and the
dance resumes just before the music does (the frame for time ``t`` is made once the music to ``t + 0.5 s``
is heard, so the look-ahead is known). The rest weight eases toward 1 over :data:`EASE_IN` s and back to 0
over :data:`EASE_OUT` s (a smoothstep of a linear ramp), which :class:`dance_core.live.rest.RestBlend` applies.
"""

from __future__ import annotations

import math

import numpy as np

#: dBFS below which audio is silence, and how far below the loudest second heard it is silence too
FLOOR_DB, RANGE_DB = -70.0, 40.0
#: seconds of silence before a frame, and after it, for the figure to rest there
HOLD, AHEAD = 0.5, 0.4
#: seconds the figure takes to come to rest, and to dance again
EASE_IN, EASE_OUT = 1.0, 0.6


class SilenceGate:
    """``push(samples)`` the audio as it arrives; ``weight(frame, known)`` the rest weight of each output frame,
    in order (frames skipped are stepped over), from 0 (dancing) to 1 (at rest). ``floor``: the silence level
    in dBFS, None never to rest. One thread pushes while another asks for weights: frames are only appended."""

    def __init__(self, fps: float, rate: int, floor: float | None = FLOOR_DB):
        self.fps, self.rate, self.floor = float(fps), int(rate), floor
        self.samples = 0  # samples heard
        self.power: list[float] = []  # per music frame completed: mean square
        self.partial = np.zeros(0, np.float32)  # samples of the frame under way
        self.window = 0.0  # the summed power of the last second's frames
        self.loudest: list[float] = []  # per frame: the loudest second heard by its end (dBFS)
        self.ramp, self.frame = 0.0, -1  # the linear ramp and the last frame it was stepped to
        self.rested = 0  # frames with a weight of at least one half

    def push(self, samples: np.ndarray) -> None:
        """The next block of mono float samples."""
        if self.floor is None:
            return
        x = np.concatenate([self.partial, np.asarray(samples, np.float32)])
        self.samples += len(samples)
        start = len(self.power)
        base = self._edge(start)  # x[0] is sample `base`
        while self._edge(len(self.power) + 1) <= self.samples:
            i = len(self.power)
            chunk = x[self._edge(i) - base : self._edge(i + 1) - base]
            self.power.append(float(np.mean(np.square(chunk, dtype=np.float64))) if len(chunk) else 0.0)
        self.partial = x[self._edge(len(self.power)) - base :]
        second = max(1, int(round(self.fps)))
        for i in range(start, len(self.power)):  # the loudest second heard by the end of each frame
            self.window += self.power[i] - (self.power[i - second] if i >= second else 0.0)
            level = _db(max(self.window, 0.0) / second) if i >= second - 1 else -math.inf
            self.loudest.append(max(self.loudest[-1] if self.loudest else -math.inf, level))

    def _edge(self, frame: int) -> int:
        """The first sample of music frame ``frame``."""
        return math.floor(frame * self.rate / self.fps + 1e-9)

    def silent(self, frame: int) -> bool:
        """Whether music frame ``frame`` (heard) is silence."""
        level = _db(self.power[frame])
        return level < self.floor or level < self.loudest[frame] - RANGE_DB

    def resting(self, frame: int, known: int) -> bool:
        """Whether the figure should rest at ``frame``: silence from :data:`HOLD` s before it to :data:`AHEAD` s
        after it, up to music frame ``known`` (nothing heard: not)."""
        lo = max(0, frame - int(round(HOLD * self.fps)))
        hi = min(len(self.power), frame + int(round(AHEAD * self.fps)) + 1, known + 1)
        return hi > lo and all(self.silent(i) for i in range(lo, hi))

    def weight(self, frame: int, known: int) -> float:
        """The rest weight at output frame ``frame`` (frames in order; a skipped one steps the ramp as well),
        deciding on the music up to frame ``known``: the frames the model's look-ahead has waited for less one
        (so the same song gives the same rests however the audio arrives)."""
        if self.floor is None:
            return 0.0
        for f in range(self.frame + 1, frame + 1):
            if self.resting(f, known):
                self.ramp = min(1.0, self.ramp + 1.0 / (EASE_IN * self.fps))
            else:
                self.ramp = max(0.0, self.ramp - 1.0 / (EASE_OUT * self.fps))
        self.frame = max(self.frame, frame)
        w = self.ramp * self.ramp * (3.0 - 2.0 * self.ramp)
        self.rested += w >= 0.5
        return w


def _db(power: float) -> float:
    """A mean square as dBFS (-inf for digital silence)."""
    return 10.0 * math.log10(power) if power > 0 else -math.inf
