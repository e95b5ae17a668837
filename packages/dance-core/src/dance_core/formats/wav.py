"""A dependency-free WAV reader: PCM 8/16/24/32-bit and IEEE float, mixed to mono."""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.media import Audio

PCM, FLOAT, EXTENSIBLE = 1, 3, 0xFFFE


def _chunks(fh, size: int):
    """``(id, offset, length)`` of each RIFF chunk, read from its header alone (nothing else is loaded)."""
    pos = 12
    while pos + 8 <= size:
        fh.seek(pos)
        cid, length = struct.unpack("<4sI", fh.read(8))
        yield cid, pos + 8, length
        pos += 8 + length + (length & 1)


def _decode(raw: bytes, fmt: int, bits: int, path: Path) -> np.ndarray:
    if fmt == PCM and bits == 8:
        return (np.frombuffer(raw, np.uint8).astype(np.float32) - 128.0) / 128.0
    if fmt == PCM and bits == 16:
        return np.frombuffer(raw, "<i2").astype(np.float32) / 32768.0
    if fmt == PCM and bits == 24:
        b = np.frombuffer(raw[: len(raw) // 3 * 3], np.uint8).reshape(-1, 3).astype(np.int32)
        v = b[:, 0] | (b[:, 1] << 8) | (b[:, 2] << 16)
        v = np.where(v >= 1 << 23, v - (1 << 24), v)
        return v.astype(np.float32) / float(1 << 23)
    if fmt == PCM and bits == 32:
        return (np.frombuffer(raw, "<i4").astype(np.float64) / 2147483648.0).astype(np.float32)
    if fmt == FLOAT and bits in (32, 64):
        return np.frombuffer(raw, "<f4" if bits == 32 else "<f8").astype(np.float32)
    raise DataError(f"{path}: unsupported WAV encoding (format {fmt}, {bits} bits)")


class WavReader:
    """Reads RIFF/WAVE files."""

    def read(self, path: str | Path, seconds: float | None = None) -> Audio:
        """Samples mixed to mono float32 and the file's rate; with ``seconds``, only the first
        ``seconds`` are read from the file (memory bounded by what is asked, not by the file)."""
        path = Path(path)
        try:
            with open(path, "rb") as fh:
                size = os.fstat(fh.fileno()).st_size
                head = fh.read(12)
                if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
                    raise DataError(f"{path}: not a WAV file (no RIFF/WAVE header)")
                fmt_chunk, data = None, None
                for cid, offset, length in _chunks(fh, size):
                    if cid == b"fmt ":
                        fh.seek(offset)
                        fmt_chunk = fh.read(min(length, 64))
                    elif cid == b"data":
                        data = (offset, min(length, size - offset))
                if fmt_chunk is None or data is None or len(fmt_chunk) < 16:
                    raise DataError(f"{path}: corrupt WAV file (missing fmt or data chunk)")
                fmt, channels, rate, _, _, bits = struct.unpack("<HHIIHH", fmt_chunk[:16])
                if fmt == EXTENSIBLE and len(fmt_chunk) >= 26:
                    fmt = struct.unpack("<H", fmt_chunk[24:26])[0]
                if channels < 1 or rate < 1:
                    raise DataError(f"{path}: corrupt WAV header ({channels} channels, {rate} Hz)")
                frame_bytes = channels * bits // 8
                if frame_bytes == 0:
                    raise DataError(f"{path}: corrupt WAV header ({bits} bits per sample)")
                length = data[1]
                if seconds is not None:
                    length = min(length, (math.ceil(max(float(seconds), 0.0) * rate) + 1) * frame_bytes)
                fh.seek(data[0])
                raw = fh.read(length // frame_bytes * frame_bytes)
        except FileNotFoundError:
            raise DataError(f"{path}: audio file not found") from None
        except OSError as exc:
            raise DataError(f"{path}: cannot read audio: {exc.strerror}") from None
        samples = _decode(raw, fmt, bits, path).reshape(-1, channels).mean(axis=1)
        if not np.all(np.isfinite(samples)):
            raise DataError(f"{path}: audio holds NaN or infinite samples")
        return Audio(np.ascontiguousarray(samples, dtype=np.float32), int(rate), path)


def write_wav(path: str | Path, samples: np.ndarray, rate: int) -> None:
    """Write mono 16-bit PCM atomically (used for synthesized demo music)."""
    samples = np.asarray(samples)
    write_wav_chunks(path, (samples[i:i + _PIECE] for i in range(0, len(samples), _PIECE)), rate)


#: samples converted at a time by :func:`write_wav_chunks`
_PIECE = 1 << 20


def write_wav_chunks(path: str | Path, chunks: Iterable[np.ndarray], rate: int) -> None:
    """Write mono 16-bit PCM given piece by piece, atomically: memory holds one piece at a time, so a long
    song costs what one piece costs (the header's sizes are filled in once the last piece is written)."""
    from dance_core.atomic import atomic_path

    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(_wav_header(0, rate))
        size = 0
        for chunk in chunks:
            pcm = np.clip(np.round(np.asarray(chunk, np.float64) * 32768.0), -32768, 32767).astype("<i2")
            fh.write(pcm.tobytes())
            size += pcm.nbytes
        if size > 0xFFFFFFFF - 36:
            raise DataError(f"{path}: {size // 2} samples do not fit in a WAV file (at most 4 GB)")
        fh.seek(0)
        fh.write(_wav_header(size, rate))


def _wav_header(size: int, rate: int) -> bytes:
    header = b"RIFF" + struct.pack("<I", 36 + size) + b"WAVE"
    fmt = b"fmt " + struct.pack("<IHHIIHH", 16, PCM, 1, rate, rate * 2, 2, 16)
    return header + fmt + b"data" + struct.pack("<I", size)


def build(config: Any = None, **_: Any) -> WavReader:
    """Build the ``wav`` reader."""
    return WavReader()
