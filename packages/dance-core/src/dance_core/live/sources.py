"""Where live audio comes from: a file played at real time, raw PCM on standard input, or a microphone.

Every source yields blocks of mono float32 samples in [-1, 1] at its ``rate`` and stops at the end of
its stream; a problem is one :class:`~dance_core.errors.DataError` line naming the input.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Iterator
from typing import BinaryIO

import numpy as np

from dance_core.errors import DataError

#: samples per block a file source hands on (23 ms at 22.05 kHz)
BLOCK = 512
#: the first bytes of audio files, which raw PCM on standard input is not
CONTAINERS = {b"RIFF": "a WAV file", b"OggS": "an Ogg file", b"fLaC": "a FLAC file", b"ID3": "an MP3 file",
              b"FORM": "an AIFF file"}


class FileSource:
    """A music file (any registered audio reader) played at ``speed`` times real time."""

    def __init__(self, path: str, registry, formats, speed: float = 1.0):
        from dance_core.data.features import load_audio

        self.name = str(path)
        self.audio = load_audio(path, registry, formats)
        self.rate, self.speed = self.audio.rate, float(speed)
        self.stop = threading.Event()

    def blocks(self) -> Iterator[np.ndarray]:
        """Blocks as the file would play: each one no earlier than its time (divided by ``speed``)."""
        y, begin = self.audio.samples, time.perf_counter()
        block = max(1, int(round(BLOCK * self.rate / 22050)))
        for lo in range(0, len(y), block):
            if self.stop.is_set():
                return
            due = begin + (lo + block) / self.rate / self.speed
            wait = due - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            yield y[lo : lo + block]

    def close(self) -> None:
        """Stop playing."""
        self.stop.set()


class PcmSource:
    """Raw signed 16-bit little-endian mono PCM at ``rate`` Hz from a binary stream (standard input).
    A stream that starts with an audio file's header is refused (it is not raw samples); one that
    sends nothing for ``idle`` seconds ends with a one-line error."""

    def __init__(self, stream: BinaryIO | None, rate: int, idle: float = 10.0, name: str = "stdin"):
        self.stream = stream if stream is not None else sys.stdin.buffer
        self.rate, self.idle, self.name = int(rate), float(idle), name
        self.closed = False

    def blocks(self) -> Iterator[np.ndarray]:
        """Blocks as they arrive (whole samples; an odd byte waits for its pair)."""
        import queue

        chunks: queue.Queue = queue.Queue()

        try:  # the file descriptor itself: a daemon thread blocked in a buffered reader aborts Python's exit
            fd = self.stream.fileno()
            read1 = lambda n: os.read(fd, n)  # noqa: E731
        except (OSError, AttributeError, ValueError):
            read1 = getattr(self.stream, "read1", self.stream.read)

        def read() -> None:
            try:
                while True:
                    data = read1(4096)
                    chunks.put(data)
                    if not data:
                        return
            except (OSError, ValueError) as exc:
                chunks.put(exc)

        threading.Thread(target=read, name="live-pcm", daemon=True).start()
        rest, first = b"", True
        while not self.closed:
            try:
                data = chunks.get(timeout=self.idle)
            except queue.Empty:
                raise DataError(f"{self.name}: no audio for {self.idle:g} s; the stream stopped") from None
            if isinstance(data, Exception):
                raise DataError(f"{self.name}: cannot read audio: {data}")
            if not data:
                return
            if first:
                self._check_raw(data)
                first = False
            data = rest + data
            whole = len(data) - len(data) % 2
            rest = data[whole:]
            if whole:
                yield np.frombuffer(data[:whole], dtype="<i2").astype(np.float32) / 32768.0

    def _check_raw(self, head: bytes) -> None:
        for magic, what in CONTAINERS.items():
            if head.startswith(magic):
                raise DataError(f"{self.name}: the stream is {what}, not raw s16le mono PCM; convert it (ffmpeg -i "
                                f"SONG -f s16le -ac 1 -ar {self.rate} -) or pass the file as --input SONG")

    def close(self) -> None:
        """Stop reading."""
        self.closed = True


class MicSource:
    """The default input device (microphone or line-in) through ``sounddevice`` (an optional extra)."""

    def __init__(self, rate: int, device: str | None = None):
        try:
            import sounddevice
        except ImportError:
            raise DataError("--input mic: no audio input library; install it with pip install "
                            "'dance-core[mic]' (sounddevice and PortAudio)") from None
        self.sd, self.rate, self.device, self.name = sounddevice, int(rate), device, "mic"
        try:
            sounddevice.check_input_settings(device=device, channels=1, samplerate=self.rate)
        except Exception as exc:  # noqa: BLE001 - PortAudio reports a missing device in many ways
            raise DataError(f"--input mic: no usable input device: {exc}") from None
        self.stop = threading.Event()

    def blocks(self) -> Iterator[np.ndarray]:
        """Blocks as the device records them."""
        import queue

        got: queue.Queue = queue.Queue()
        with self.sd.InputStream(samplerate=self.rate, channels=1, dtype="float32", device=self.device,
                                 callback=lambda data, *_: got.put(data[:, 0].copy())):
            while not self.stop.is_set():
                try:
                    yield got.get(timeout=0.5)
                except queue.Empty:
                    continue

    def close(self) -> None:
        """Stop recording."""
        self.stop.set()


def open_source(spec: str, rate: int | None, speed: float, registry, formats):
    """``-`` (raw PCM on standard input at ``rate``), ``mic`` (the default input device) or a music file."""
    if spec == "-":
        return PcmSource(None, rate or 22050)
    if spec == "mic":
        return MicSource(rate or 22050)
    return FileSource(spec, registry, formats, speed)
