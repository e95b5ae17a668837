"""A dependency-free WAV reader: PCM 8/16/24/32-bit and IEEE float, mixed to mono."""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.media import Audio

PCM, FLOAT, EXTENSIBLE = 1, 3, 0xFFFE


def _chunks(data: bytes, path: Path):
    pos = 12
    while pos + 8 <= len(data):
        cid, size = struct.unpack("<4sI", data[pos : pos + 8])
        yield cid, data[pos + 8 : pos + 8 + size]
        pos += 8 + size + (size & 1)


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

    def read(self, path: str | Path) -> Audio:
        """Samples mixed to mono float32 and the file's rate."""
        path = Path(path)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            raise DataError(f"{path}: audio file not found") from None
        except OSError as exc:
            raise DataError(f"{path}: cannot read audio: {exc.strerror}") from None
        if len(data) < 12 or data[:4] != b"RIFF" or data[8:12] != b"WAVE":
            raise DataError(f"{path}: not a WAV file (no RIFF/WAVE header)")
        fmt_chunk, raw = None, None
        for cid, body in _chunks(data, path):
            if cid == b"fmt ":
                fmt_chunk = body
            elif cid == b"data":
                raw = body
        if fmt_chunk is None or raw is None or len(fmt_chunk) < 16:
            raise DataError(f"{path}: corrupt WAV file (missing fmt or data chunk)")
        fmt, channels, rate, _, _, bits = struct.unpack("<HHIIHH", fmt_chunk[:16])
        if fmt == EXTENSIBLE and len(fmt_chunk) >= 26:
            fmt = struct.unpack("<H", fmt_chunk[24:26])[0]
        if channels < 1 or rate < 1:
            raise DataError(f"{path}: corrupt WAV header ({channels} channels, {rate} Hz)")
        frame_bytes = channels * bits // 8
        if frame_bytes == 0:
            raise DataError(f"{path}: corrupt WAV header ({bits} bits per sample)")
        raw = raw[: len(raw) // frame_bytes * frame_bytes]
        samples = _decode(raw, fmt, bits, path).reshape(-1, channels).mean(axis=1)
        if not np.all(np.isfinite(samples)):
            raise DataError(f"{path}: WAV holds non-finite samples")
        return Audio(np.ascontiguousarray(samples, dtype=np.float32), int(rate), path)


def write_wav(path: str | Path, samples: np.ndarray, rate: int) -> None:
    """Write mono 16-bit PCM atomically (used for synthesized demo music)."""
    from dance_core.atomic import write_bytes

    pcm = np.clip(np.round(np.asarray(samples, np.float64) * 32768.0), -32768, 32767).astype("<i2").tobytes()
    header = b"RIFF" + struct.pack("<I", 36 + len(pcm)) + b"WAVE"
    fmt = b"fmt " + struct.pack("<IHHIIHH", 16, PCM, 1, rate, rate * 2, 2, 16)
    write_bytes(path, header + fmt + b"data" + struct.pack("<I", len(pcm)) + pcm)


def build(config: Any = None, **_: Any) -> WavReader:
    """Build the ``wav`` reader."""
    return WavReader()
