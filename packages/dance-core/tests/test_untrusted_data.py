"""Issue 28, untrusted data files: songs, motion files, checkpoints and text spans. Each table row is a
file's content and the text its one error line must hold; every error names the file, is a DanceError
(never numpy's words or a traceback), and comes before memory is spent on what the header promises."""

from __future__ import annotations

import io
import json
import struct
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from dance_core.errors import CheckpointError, DanceError, DataError

sys.path.insert(0, str(Path(__file__).parent))
from test_reliability import BVH  # noqa: E402

# ---------------------------------------------------------------------------------------------------- WAV


def wav(rate: int = 16000, fmt: int = 1, bits: int = 16, channels: int = 1, data: bytes | None = None,
        fmt_chunk: bool = True, riff: bytes = b"RIFF") -> bytes:
    """A WAV file's bytes, every header field as given (hostile ones included)."""
    if data is None:
        data = (np.sin(np.arange(16000) / 5) * 8000).astype("<i2").tobytes()
    block = channels * bits // 8
    body = b"WAVE"
    if fmt_chunk:
        body += b"fmt " + struct.pack("<IHHIIHH", 16, fmt, channels, rate, rate * block, block, bits)
    body += b"data" + struct.pack("<I", len(data)) + data
    return riff + struct.pack("<I", len(body)) + body


def floats(values) -> bytes:
    return np.asarray(values, "<f4").tobytes()


WAVS = [
    (wav(rate=0), "0 Hz"),
    (wav(channels=0), ""),
    (wav(bits=0), ""),
    (wav(fmt_chunk=False), ""),
    (wav(riff=b"RIFX"), ""),
    (b"RIFF\x00\x00\x00\x00WAVE", ""),
    (wav(fmt=3, bits=32, data=floats(np.full(16000, 1e30))), "far outside [-1, 1]"),
    (wav(fmt=3, bits=32, data=floats(np.r_[np.zeros(8000), 3e4, np.zeros(7999)])), "samples reach 3e+04"),
    (wav(fmt=3, bits=32, data=floats(np.r_[np.zeros(8000), np.nan, np.zeros(7999)])), "NaN or infinite"),
    (wav(fmt=3, bits=32, data=floats(np.r_[np.zeros(8000), np.inf, np.zeros(7999)])), "NaN or infinite"),
    (wav(fmt=3, bits=32, data=floats(np.r_[np.zeros(8000), -np.inf, np.zeros(7999)])), "NaN or infinite"),
    (wav(fmt=99, bits=8), ""),
    (wav(data=b""), ""),
    (wav(data=b"\x00" * 1000), "long"),
]


@pytest.mark.parametrize("content, expected", WAVS, ids=[f"wav{k}" for k in range(len(WAVS))])
@pytest.mark.parametrize("reader", ["core", "installed"])
def test_a_hostile_wav_is_one_line_naming_the_file(tmp_path, content, expected, reader):
    from dance_core.data.features import check_audio, load_audio
    from dance_core.formats.wav import WavReader
    from dance_core.registry import get_registry

    path = tmp_path / "song.wav"
    path.write_bytes(content)
    with pytest.raises(DanceError) as err:
        if reader == "core":
            check_audio(WavReader().read(path), path)
            load_audio(path, get_registry())  # the length check lives there
        else:
            load_audio(path, get_registry())
    message = str(err.value)
    assert message.startswith(f"{path}: ") and "\n" not in message and expected in message, message


def test_audio_within_a_few_times_full_scale_is_read_as_it_is(tmp_path):
    from dance_core.data.features import load_audio
    from dance_core.registry import get_registry

    path = tmp_path / "loud.wav"
    samples = np.sin(np.arange(16000) / 5) * 4.0  # a float mix 12 dB over full scale: loud, not damaged
    path.write_bytes(wav(fmt=3, bits=32, data=floats(samples)))
    audio = load_audio(path, get_registry())
    assert np.allclose(audio.samples, samples.astype(np.float32))


@pytest.mark.parametrize("reader", ["core", "installed"])
def test_seconds_decodes_only_what_is_asked(tmp_path, reader):
    from dance_core.data.features import load_audio, read_audio
    from dance_core.formats.wav import WavReader, write_wav
    from dance_core.registry import get_registry

    path = tmp_path / "long.wav"
    rate = 16000
    song = np.sin(np.arange(rate * 300) / 7.0) * 0.5  # 300 s: 19 MB as float32
    write_wav(path, song, rate)
    whole = WavReader().read(path).samples
    tracemalloc.start()
    try:
        if reader == "core":
            audio = read_audio(WavReader(), path, 5.0)
        else:
            audio = load_audio(path, get_registry(), seconds=5.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(audio.samples) == 5 * rate
    assert np.array_equal(audio.samples, whole[: 5 * rate])
    assert peak < 4e6  # a few seconds of samples, never the 19 MB of the whole song


# ---------------------------------------------------------------------------------------------------- BVH


BVHS = [
    ("Frames: 3", "Frames: 1000000000", ":17: BVH MOTION: 1000000000 frames of 9 channels declared, found 3 lines"),
    ("Frames: 3", "Frames: " + "9" * 30, "frames of 9 channels declared"),
    ("Frames: 3", "Frames: " + "9" * 5000, "is not a plausible number"),
    ("Frames: 3", "Frames: 1e5", "Frames '1e5' is not a number"),
    ("Frames: 3", "Frames: -1", "negative frame count"),
    ("Frames: 3", "Frames: nan", "is not a number"),
    ("Frame Time: 0.033333", "Frame Time: 0", "frame time must be positive"),
    ("Frame Time: 0.033333", "Frame Time: -0.1", "frame time must be positive"),
    ("Frame Time: 0.033333", "Frame Time: nan", "is not a finite number"),
    ("Frame Time: 0.033333", "Frame Time: inf", "is not a finite number"),
    ("Frame Time: 0.033333", "Frame Time: 1e999", "is not a finite number"),
    ("Frame Time: 0.033333", "Frame Time: " + "1" * 50, "is not a plausible number"),
    ("MOTION\n", "", "no MOTION section"),
    ("HIERARCHY\n", "", "no HIERARCHY"),
    ("0 1 0 0 10 0 0 0 0\n", "0 1 0 0 10 0 0 0 1e400\n", "holds '1e400'"),
    ("0 1 0 0 10 0 0 0 0\n", "0 1 0 0 10 0 0 0 -inf\n", "holds '-inf'"),
    ("\tOFFSET 0 0 0\n", "\tOFFSET 0 0 1e999\n", "is not a finite"),
    ("CHANNELS 6", "CHANNELS 600000000", "BVH HIERARCHY"),
]


@pytest.mark.parametrize("old, new, expected", BVHS, ids=[f"bvh{k}" for k in range(len(BVHS))])
def test_a_hostile_bvh_is_one_line_naming_the_file_before_allocating(tmp_path, old, new, expected):
    from dance_core.formats.bvh import BvhFormat

    assert old in BVH
    path = tmp_path / "dance.bvh"
    path.write_text(BVH.replace(old, new, 1))
    tracemalloc.start()
    try:
        with pytest.raises(DataError) as err:
            BvhFormat().read(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    message = str(err.value)
    assert message.startswith(f"{path}:") and "\n" not in message and expected in message, message
    assert peak < 50e6


@pytest.mark.parametrize("prefix", ["\ufeff", "\ufeff\n", "\n\n"])
def test_a_bvh_with_a_byte_order_mark_or_leading_blank_lines_reads(tmp_path, prefix):
    from dance_core.formats.bvh import BvhFormat

    path = tmp_path / "bom.bvh"
    path.write_bytes((prefix + BVH).encode("utf-8"))
    plain = tmp_path / "plain.bvh"
    plain.write_text(BVH)
    assert np.array_equal(BvhFormat().read(path).values, BvhFormat().read(plain).values)


# ---------------------------------------------------------------------------------------------------- NPZ


def npz(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


GOOD = {"values": np.zeros((4, 3), np.float32), "fps": np.float64(30.0), "channels": np.array(["a.x", "a.y", "a.z"])}

NPZS = [
    (npz(**{**GOOD, "values": np.ones((4, 3), np.complex64)}), "values: complex64 numbers; motion must be real"),
    (npz(**{**GOOD, "values": np.ones((4, 3), np.complex128) * 1j}), "complex128"),
    (npz(**{**GOOD, "values": np.ones((4, 3), bool)}), "values: bool numbers"),
    (npz(**{**GOOD, "values": np.array([["a", "b", "c"]])}), "motion must be real numbers"),
    (npz(**{**GOOD, "values": np.zeros(12, np.float32)}), "values must be (frames, channels)"),
    (npz(**{**GOOD, "values": np.zeros((2, 2, 3), np.float32)}), "values must be (frames, channels)"),
    (npz(**{**GOOD, "fps": np.array([30.0, 60.0])}), "fps: expected one real number"),
    (npz(**{**GOOD, "fps": np.array("thirty")}), "fps: expected one real number"),
    (npz(**{**GOOD, "fps": np.float64(0.0)}), "fps: must be a positive frame rate, got 0"),
    (npz(**{**GOOD, "fps": np.float64(-30.0)}), "must be a positive frame rate"),
    (npz(**{**GOOD, "fps": np.float64(np.nan)}), "must be a positive frame rate, got nan"),
    (npz(**{**GOOD, "fps": np.float64(np.inf)}), "must be a positive frame rate, got inf"),
    (npz(**{**GOOD, "fps": np.float64(1e300)}), "must be a positive frame rate"),
    (npz(**{**GOOD, "channels": np.array(["a.x"])}), "channels: 1 names for 3 value columns"),
    (npz(fps=np.float64(30.0)), "not a dance motion NPZ (missing"),
    (npz(values=np.zeros((4, 3))), "not a dance motion NPZ (missing"),
    (npz(**{**GOOD, "values": np.array([{"a": 1}], dtype=object)}), "corrupt motion NPZ"),
    (b"PK\x03\x04 not really a zip", "corrupt motion NPZ"),
    (b"just text", "corrupt motion NPZ"),
    (npz(**GOOD)[:60], "corrupt motion NPZ"),
]


@pytest.mark.parametrize("content, expected", NPZS, ids=[f"npz{k}" for k in range(len(NPZS))])
def test_a_hostile_npz_is_one_line_naming_the_file(tmp_path, content, expected):
    from dance_core.formats.npz import NpzFormat

    path = tmp_path / "clip.npz"
    path.write_bytes(content)
    with pytest.raises(DataError) as err:
        NpzFormat().read(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and "\n" not in message and expected in message, message


# ----------------------------------------------------------------------------------- checkpoint metadata


def _checkpoint(path: Path, **meta) -> None:
    import torch

    from dance_core.checkpoint import FORMAT, write_safetensors

    base = {"format": FORMAT, "recipe": "{}", "motion": '{"dim": 2, "fps": 30.0}', "versions": "{}", "step": "1"}
    write_safetensors(path, {"model.w": torch.zeros(2)}, {**base, **meta})


CHECKPOINTS = [
    ({"recipe": "[1, 2]"}, "recipe is a list, not a dict"),
    ({"recipe": "null"}, "recipe is a NoneType"),
    ({"motion": "42"}, "motion is a int, not a dict"),
    ({"motion": '"text"'}, "motion is a str"),
    ({"versions": "[]"}, "versions is a list"),
    ({"recipe": "{not json"}, "corrupt checkpoint metadata"),
    ({"step": "-3"}, "step '-3' is not a step count"),
    ({"step": "1e3"}, "is not a step count"),
    ({"step": "9" * 5000}, "is not a step count"),
    ({"step": "١٢"}, "is not a step count"),
    ({"format": "other"}, "not a dance checkpoint"),
]


@pytest.mark.parametrize("meta, expected", CHECKPOINTS, ids=[f"ckpt{k}" for k in range(len(CHECKPOINTS))])
def test_checkpoint_metadata_of_the_wrong_type_is_one_line(tmp_path, meta, expected):
    from dance_core.checkpoint import load_checkpoint

    path = tmp_path / "model.safetensors"
    _checkpoint(path, **meta)
    with pytest.raises(CheckpointError) as err:
        load_checkpoint(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and "\n" not in message and expected in message, message


HEADERS = [
    struct.pack("<Q", 2**63) + b"{}",
    struct.pack("<Q", 100) + b"{}",
    struct.pack("<Q", 2) + b"[]",
    struct.pack("<Q", 8) + b'{"a":1} ',
    struct.pack("<Q", 30) + b'{"__metadata__":{"a":1}}      ',
    struct.pack("<Q", 60) + b'{"w":{"dtype":"F32","shape":[1000000],"data_offsets":[0,4000000]}}',
    b"\x00" * 4,
    b"",
]


@pytest.mark.parametrize("content", HEADERS, ids=[f"header{k}" for k in range(len(HEADERS))])
def test_a_damaged_safetensors_header_is_one_line(tmp_path, content):
    from dance_core.checkpoint import load_checkpoint, train_state_info

    path = tmp_path / "model.safetensors"
    path.write_bytes(content)
    for load in (load_checkpoint, train_state_info):
        with pytest.raises(CheckpointError) as err:
            load(path)
        assert str(err.value).startswith(f"{path}: ") and "\n" not in str(err.value)


# ------------------------------------------------------------------------------------------------ text spans


SPANS = ["-5-3: jump", "3: jump", "1e3-2e3: jump", "1-2-3: jump", "--3: jump", "1.2.3-4: jump", "+1-2: jump",
         " 5 : jump"]


@pytest.mark.parametrize("given", SPANS)
def test_a_malformed_span_is_an_error_naming_it_not_whole_song_text(given, capsys):
    from dance_core.cli.main import main

    code = main(["compose", "tm2d-small", "--music", "x.wav", "--text", given])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and f"--text {given!r}: malformed span" in err, err


@pytest.mark.parametrize("given, span", [("20-30: a person jumps", (20.0, 30.0, "a person jumps")),
                                         ("-30: jump", (None, 30.0, "jump")), ("5-: spin", (5.0, None, "spin")),
                                         ("a person: jumps", (None, None, "a person: jumps")),
                                         ("1980s-1990s: retro", (None, None, "1980s-1990s: retro"))])
def test_well_formed_spans_and_plain_text_still_parse(given, span):
    from dance_core.recipe.schema import TextSpec

    t = TextSpec.parse(given)
    assert (t.start, t.end, t.text) == span


def test_every_table_is_counted_in_the_corpus():
    from test_untrusted import HOSTILE, RECIPES, SETS, SPECIAL

    total = (2 * len(WAVS) + len(BVHS) + len(NPZS) + len(CHECKPOINTS) + len(HEADERS) + len(SPANS)
             + 2 * len(HOSTILE) + len(RECIPES) + len(SETS) + 3 * len(SPECIAL) + 2 * len(SPECIAL))
    assert total >= 150
    assert json.dumps(total)
