"""Audio files to mono float32 samples: soundfile (wav, flac, ogg, mp3), audioread as a fallback.

Files are checked before and after decoding: a file that is text (a renamed document) is refused
before any decoder sees it, and a truncated file (an Ogg stream without its last page, a WAV whose
data chunk is shorter than its header says, a FLAC or AIFF shorter than its frame count) is an
error, not a shorter song.
"""

from __future__ import annotations

import struct
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from dance_core import Audio, DataError, check_audio_path

SUFFIXES = (".wav", ".wave", ".flac", ".ogg", ".oga", ".mp3", ".aif", ".aiff")
SILENCE = 1e-4  # peak amplitude below which a file counts as silent
SHORT_SECONDS = 1.0


def _wanted(seconds: float | None, rate: int) -> int | None:
    """Frames to decode for the first ``seconds`` (None: all)."""
    return None if seconds is None else int(np.ceil(max(float(seconds), 0.0) * rate)) + 1


def _read_soundfile(path: Path, seconds: float | None = None) -> tuple[np.ndarray, int]:
    import soundfile as sf

    with sf.SoundFile(str(path)) as f:
        rate = int(f.samplerate)
        if rate < 1:
            raise DataError(f"{path}: audio header gives a sample rate of {rate} Hz; the file is damaged")
        want = _wanted(seconds, rate)
        data = f.read(-1 if want is None else want, dtype="float32", always_2d=True)
    return data.mean(axis=1), rate


def _read_audioread(path: Path, seconds: float | None = None) -> tuple[np.ndarray, int]:
    chunks, have = [], 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # audioread imports aifc, audioop, sunau
        import audioread

        with audioread.audio_open(str(path)) as f:
            rate, channels = int(f.samplerate), int(f.channels)
            if rate < 1 or channels < 1:
                raise DataError(f"{path}: audio header gives {rate} Hz, {channels} channels; the file is damaged")
            want = _wanted(seconds, rate)
            for buf in f:
                chunks.append(np.frombuffer(buf, "<i2"))
                have += len(chunks[-1]) // channels
                if want is not None and have >= want:
                    break
    pcm = np.concatenate(chunks) if chunks else np.zeros(0, "<i2")
    pcm = pcm[: len(pcm) // channels * channels].reshape(-1, channels)
    return pcm.astype(np.float32).mean(axis=1) / 32768.0, rate


#: leading bytes of the audio containers we know (an offset, the bytes)
MAGIC = {
    "wav": (0, b"RIFF"), "ogg": (0, b"OggS"), "flac": (0, b"fLaC"), "id3": (0, b"ID3"), "aiff": (0, b"FORM"),
    "mp4": (4, b"ftyp"), "asf": (0, b"\x30\x26\xb2\x75"), "caf": (0, b"caff"), "au": (0, b".snd"),
    "wav64": (0, b"RF64"),
}


def container(head: bytes) -> str | None:
    """The audio container the first bytes of a file announce (MPEG audio by its frame sync), or None."""
    for name, (offset, magic) in MAGIC.items():
        if head[offset : offset + len(magic)] == magic:
            return name
    if len(head) >= 2 and head[0] == 0xFF and head[1] & 0xE0 == 0xE0:
        return "mpeg"
    return None


def text_start(head: bytes) -> str | None:
    """The first line when ``head`` reads as text (UTF-8, printable), else None."""
    text = None
    for cut in range(4):  # the read may end inside a multi-byte character
        try:
            text = head[: len(head) - cut].decode("utf-8")
            break
        except UnicodeDecodeError:
            continue
    if text is None:
        return None
    printable = sum(ch.isprintable() or ch in "\t\r\n" for ch in text)
    if not text.strip() or printable < 0.97 * len(text):
        return None
    return text.strip().splitlines()[0][:40]


def ogg_problem(path: Path) -> str | None:
    """Why an Ogg file is cut off or damaged (a page running past the end, a stream that never
    reaches its end-of-stream page, no page where one should start), or None when it is whole."""
    size = path.stat().st_size
    open_streams: set[bytes] = set()
    pos = 0
    with open(path, "rb") as fh:
        while pos < size:
            fh.seek(pos)
            head = fh.read(27)
            if head[:4] != b"OggS":
                if pos > 0 and not open_streams:
                    return None  # trailing bytes after every stream ended
                return f"no Ogg page where one should start (byte {pos} of {size})"
            if len(head) < 27:
                return f"the last Ogg page is cut off (byte {pos} of {size})"
            lacing = fh.read(head[26])
            end = pos + 27 + len(lacing) + sum(lacing)
            if len(lacing) < head[26] or end > size:
                return f"the last Ogg page is cut off (it starts at byte {pos} and needs {end} of {size})"
            flags, serial = head[5], head[14:18]
            if flags & 0x02:
                open_streams.add(serial)
            if flags & 0x04:
                open_streams.discard(serial)
            pos = end
    if open_streams:
        return "the Ogg stream ends without its last page"
    return None


def wav_problem(path: Path) -> str | None:
    """Why a RIFF/WAVE file is cut off (its data chunk declares more bytes than the file holds), or None."""
    size = path.stat().st_size
    byte_rate = 0
    with open(path, "rb") as fh:
        pos = 12
        while pos + 8 <= size:
            fh.seek(pos)
            cid, length = struct.unpack("<4sI", fh.read(8))
            if cid == b"fmt ":
                fmt = fh.read(min(length, 16))
                byte_rate = struct.unpack("<I", fmt[8:12])[0] if len(fmt) >= 12 else 0
            if cid == b"data":
                if length in (0, 0xFFFFFFFF):  # written by a stream that never knew its length
                    return None
                have = size - pos - 8
                if length > have:
                    if byte_rate:
                        return (f"the file holds {have / byte_rate:.2f} s of the {length / byte_rate:.2f} s "
                                "its header declares")
                    return f"the data chunk declares {length} bytes, the file holds {have}"
                return None
            pos += 8 + length + (length & 1)
    return None


def frames_problem(path: Path, decoded: int) -> str | None:
    """Why a FLAC or AIFF file decoded to fewer frames than its header's count, or None."""
    try:
        import soundfile as sf

        info = sf.info(str(path))
    except Exception:
        return None
    if info.format not in ("FLAC", "AIFF") or info.frames <= 0 or decoded >= info.frames:
        return None
    return (f"it decodes to {decoded / info.samplerate:.2f} s of the {info.frames / info.samplerate:.2f} s "
            "its header declares")


def completeness_problem(path: Path, kind: str | None, decoded: int) -> str | None:
    """Why a decoded file is not whole (see :func:`ogg_problem`, :func:`wav_problem`,
    :func:`frames_problem`), or None."""
    if kind == "ogg":
        return ogg_problem(path)
    if kind == "wav":
        return wav_problem(path)
    return frames_problem(path, decoded)


def _reason(exc: BaseException) -> str:
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    # libsndfile says "File does not exist or is not a regular file" for files it cannot identify
    if "does not exist or is not a regular file" in text:
        return "no decoder recognises its content"
    return text.strip().rstrip(".")


class SoundFileReader:
    """Reads any format libsndfile knows; falls back to audioread (ffmpeg, GStreamer) for the rest."""

    def read(self, path: str | Path, seconds: float | None = None) -> Audio:
        """Samples mixed to mono float32 in [-1, 1] at the file's own rate; a text file, an
        undecodable file or a truncated one is a one-line error. With ``seconds``, only the first
        ``seconds`` are decoded (memory bounded by what is asked, whatever the file's length)."""
        path = check_audio_path(path)
        with open(path, "rb") as fh:
            head = fh.read(512)
        kind = container(head)
        if kind is None:
            line = text_start(head)
            if line is not None:
                raise DataError(f"{path}: cannot decode audio: it is a text file, not audio (it starts {line!r})")
        try:
            samples, rate = _read_soundfile(path, seconds)
        except DataError:
            raise
        except Exception as first:  # libsndfile cannot decode it: try the system decoders
            try:
                samples, rate = _read_audioread(path, seconds)
            except DataError:
                raise
            except Exception:
                if kind is None:
                    raise DataError(f"{path}: cannot decode audio: not an audio file any decoder knows "
                                    f"({_reason(first)})") from None
                problem = completeness_problem(path, kind, 0) if kind in ("ogg", "wav") else None
                if problem is None and kind in ("flac", "aiff"):
                    problem = _reason(first)
                detail = f"truncated or damaged: {problem}" if problem else _reason(first)
                raise DataError(f"{path}: cannot decode audio ({detail})") from None
        want = _wanted(seconds, rate)
        # only a part was decoded: a FLAC/AIFF is whole when that part was (header-checked kinds as ever)
        decoded = len(samples) if want is None or len(samples) < want else 1 << 62
        problem = completeness_problem(path, kind, decoded)
        if problem:
            raise DataError(f"{path}: audio is truncated or damaged: {problem}")
        if len(samples) == 0:
            raise DataError(f"{path}: audio file holds no samples")
        if not np.all(np.isfinite(samples)):
            raise DataError(f"{path}: audio holds NaN or infinite samples")
        check_content(samples, rate, path)
        return Audio(np.ascontiguousarray(samples, dtype=np.float32), rate, path)


def check_content(samples: np.ndarray, rate: int, path: Path | None) -> None:
    """Warn (not fail) on silence and on very short clips: features stay well defined for both."""
    name = path if path is not None else "audio"
    if rate < 1:
        raise DataError(f"{name}: audio header gives a sample rate of {rate} Hz; the file is damaged")
    if float(np.max(np.abs(samples))) < SILENCE:
        warnings.warn(f"{name}: audio is silent; features will be constant", stacklevel=3)
    if len(samples) / rate < SHORT_SECONDS:
        warnings.warn(f"{name}: audio is only {len(samples) / rate:.2f} s long", stacklevel=3)


def build(config: Any = None, **_: Any) -> SoundFileReader:
    """Build the ``soundfile`` reader."""
    return SoundFileReader()
