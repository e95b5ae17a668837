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
import threading
from collections import deque

import numpy as np

#: dBFS below which audio is silence, and how far below the loudest second heard it is silence too
FLOOR_DB, RANGE_DB = -70.0, 40.0
#: seconds of silence before a frame, and after it, for the figure to rest there
HOLD, AHEAD = 0.5, 0.4
#: seconds the figure takes to come to rest, and to dance again
EASE_IN, EASE_OUT = 1.0, 0.6
#: seconds of frames' silence kept (the frames asked about are within a second or two of the newest)
MEMORY = 60.0


class SilenceGate:
    """``push(samples)`` the audio as it arrives; ``weight(frame, known)`` the rest weight of each output frame,
    in order (frames skipped are stepped over), from 0 (dancing) to 1 (at rest). ``floor``: the silence level
    in dBFS, None never to rest. One thread may push while another asks for weights; the last
    :data:`MEMORY` s of frames are kept, so a session of hours holds no more than a session of minutes."""

    def __init__(self, fps: float, rate: int, floor: float | None = FLOOR_DB):
        self.fps, self.rate, self.floor = float(fps), int(rate), floor
        self.samples = 0  # samples heard
        self.frames = 0  # music frames completed
        self.partial = np.zeros(0, np.float32)  # samples of the frame under way
        second = max(1, int(round(self.fps)))
        self.recent: deque[float] = deque(maxlen=second)  # the last second's frame powers (mean squares)
        self.loudest = -math.inf  # the loudest second heard (dBFS)
        self.silence: deque[bool] = deque(maxlen=max(1, int(round(MEMORY * self.fps))))  # per frame, newest last
        self.lock = threading.Lock()
        self.ramp, self.frame = 0.0, -1  # the linear ramp and the last frame it was stepped to
        self.rested = 0  # frames with a weight of at least one half

    def push(self, samples: np.ndarray) -> None:
        """The next block of mono float samples."""
        if self.floor is None:
            return
        x = np.concatenate([self.partial, np.asarray(samples, np.float32)])
        self.samples += len(samples)
        base = self._edge(self.frames)  # x[0] is sample `base`
        while self._edge(self.frames + 1) <= self.samples:
            chunk = x[self._edge(self.frames) - base : self._edge(self.frames + 1) - base]
            power = float(np.mean(np.square(chunk, dtype=np.float64))) if len(chunk) else 0.0
            self.recent.append(power)
            if len(self.recent) == self.recent.maxlen:  # the loudest second heard by the end of this frame
                self.loudest = max(self.loudest, _db(sum(self.recent) / len(self.recent)))
            quiet = self.quiet(_db(power))
            with self.lock:
                self.silence.append(quiet)
                self.frames += 1
        self.partial = x[self._edge(self.frames) - base :]

    def quiet(self, level: float) -> bool:
        """Whether a frame at ``level`` dBFS, heard now, is silence."""
        return level < self.floor or level < self.loudest - RANGE_DB

    def _edge(self, frame: int) -> int:
        """The first sample of music frame ``frame``."""
        return math.floor(frame * self.rate / self.fps + 1e-9)

    def silent(self, frame: int) -> bool:
        """Whether music frame ``frame`` (heard, and among the last :data:`MEMORY` s) is silence."""
        with self.lock:
            k = frame - (self.frames - len(self.silence))
            return 0 <= k < len(self.silence) and self.silence[k]

    def resting(self, frame: int, known: int) -> bool:
        """Whether the figure should rest at ``frame``: silence from :data:`HOLD` s before it to :data:`AHEAD` s
        after it, up to music frame ``known`` (nothing heard: not)."""
        lo = max(0, frame - int(round(HOLD * self.fps)))
        hi = min(self.frames, frame + int(round(AHEAD * self.fps)) + 1, known + 1)
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
