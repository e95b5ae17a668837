"""Truncated and mislabelled audio are one-line errors, not shorter songs or "does not exist"."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from dance_audio.reader import SoundFileReader, ogg_problem, text_start
from dance_core.errors import DataError

OGGS = ["vibe_ace.ogg", "hungarian_dance_5.ogg", "sugar_plum_fairy.ogg", "lets_go_fishin.ogg"]


@pytest.mark.parametrize("name", OGGS)
def test_whole_ogg_fixtures_are_complete(audio_dir, name):
    assert ogg_problem(audio_dir / name) is None


@pytest.mark.parametrize("fraction", [0.5, 0.9, 0.999])
def test_a_truncated_ogg_is_detected(tmp_path, audio_dir, fraction):
    data = (audio_dir / "lets_go_fishin.ogg").read_bytes()
    cut = tmp_path / "cut.ogg"
    cut.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(DataError) as err:
        SoundFileReader().read(cut)
    message = str(err.value)
    assert message.startswith(f"{cut}: audio is truncated or damaged: ") and "Ogg" in message and "\n" not in message


def test_an_ogg_cut_at_a_page_boundary_misses_its_last_page(tmp_path, audio_dir):
    data = (audio_dir / "vibe_ace.ogg").read_bytes()
    last_page = data.rindex(b"OggS")
    cut = tmp_path / "cut.ogg"
    cut.write_bytes(data[:last_page])  # every page whole, the end-of-stream page gone
    with pytest.raises(DataError, match="ends without its last page"):
        SoundFileReader().read(cut)


def test_a_truncated_wav_and_flac_are_detected(tmp_path, audio_dir):
    data = (audio_dir / "sample.wav").read_bytes()
    wav = tmp_path / "cut.wav"
    wav.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(DataError, match=r"cut\.wav: audio is truncated or damaged: the file holds 1\.8\d s of the "
                                         r"2\.80 s its header declares"):
        SoundFileReader().read(wav)
    samples, rate = sf.read(audio_dir / "sample.wav", dtype="float32")
    flac = tmp_path / "whole.flac"
    sf.write(flac, samples, rate)
    assert SoundFileReader().read(flac).duration == pytest.approx(2.8, abs=0.01)
    cut = tmp_path / "cut.flac"
    cut.write_bytes(flac.read_bytes()[: flac.stat().st_size // 2])
    with pytest.raises(DataError, match=r"cut\.flac: .*truncated or damaged"):
        SoundFileReader().read(cut)


def test_a_wav_of_unknown_length_still_loads(tmp_path, audio_dir):
    data = bytearray((audio_dir / "sample.wav").read_bytes())
    at = data.index(b"data")
    data[at + 4 : at + 8] = b"\xff\xff\xff\xff"  # what a streaming writer leaves
    path = tmp_path / "stream.wav"
    path.write_bytes(bytes(data))
    assert SoundFileReader().read(path).duration == pytest.approx(2.8, abs=0.01)


@pytest.mark.parametrize("suffix", [".mp3", ".ogg", ".wav", ".flac"])
def test_a_text_file_named_as_audio_says_it_is_text(tmp_path, suffix):
    path = tmp_path / f"song{suffix}"
    path.write_text("Verse 1: la la la, these are the lyrics\n" * 5, encoding="utf-8")
    with pytest.raises(DataError) as err:
        SoundFileReader().read(path)
    message = str(err.value)
    first = "Verse 1: la la la, these are the lyrics"
    assert message == f"{path}: cannot decode audio: it is a text file, not audio (it starts {first!r})"
    assert "does not exist" not in message


def test_binary_junk_is_not_audio_and_never_does_not_exist(tmp_path):
    path = tmp_path / "junk.mp3"
    path.write_bytes(b"\x00\x01" + np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8).tobytes())
    with pytest.raises(DataError) as err:
        SoundFileReader().read(path)
    assert "cannot decode audio" in str(err.value) and "does not exist" not in str(err.value)


def test_text_start_reads_text_and_refuses_binary():
    assert text_start("héllo wörld\nmore".encode()) == "héllo wörld"
    assert text_start("la la é".encode()[:-1]) == "la la"  # the read ended inside a character
    assert text_start(b"\x00\x01\x02binary") is None
    assert text_start(b"   \n  ") is None
