"""A stand-in for the ``sounddevice`` library in the tests of ``dance live --input mic``: one input device that
records a click track (120 BPM over a low hum) at real time, block by block, through the callback, as PortAudio's
input streams do. With ``FAKE_AUDIO_DEVICE=none`` in the environment there is no input device."""

from __future__ import annotations

import os
import threading
import time

import numpy as np


class PortAudioError(Exception):
    """What sounddevice raises for device errors."""


def check_input_settings(device=None, channels=None, dtype=None, extra_settings=None, samplerate=None):
    """Raise as sounddevice does where there is no input device."""
    if os.environ.get("FAKE_AUDIO_DEVICE") == "none":
        raise PortAudioError("Error querying device -1")


class InputStream:
    """Calls ``callback(indata (frames, 1) float32, frames, time, status)`` every ``blocksize`` samples in real time
    from a thread, while the stream is open (a context manager, as sounddevice's)."""

    def __init__(self, samplerate, channels, dtype, device=None, callback=None, blocksize=1024):
        self.rate, self.callback, self.blocksize = int(samplerate), callback, int(blocksize)
        self.running = threading.Event()
        self.thread = threading.Thread(target=self._record, daemon=True)

    def _record(self) -> None:
        start, done = time.perf_counter(), 0
        while self.running.is_set():
            t = (done + np.arange(self.blocksize)) / self.rate
            click = np.where((t % 0.5) < 0.01, np.sin(2 * np.pi * 2000 * t), 0.0)
            block = (0.4 * click + 0.05 * np.sin(2 * np.pi * 110 * t)).astype(np.float32)[:, None]
            self.callback(block, self.blocksize, None, None)
            done += self.blocksize
            time.sleep(max(0.0, start + done / self.rate - time.perf_counter()))

    def __enter__(self):
        self.running.set()
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.running.clear()
        self.thread.join()
        return False
