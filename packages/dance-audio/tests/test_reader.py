from __future__ import annotations

import warnings

import numpy as np
import pytest
import soundfile as sf

from dance_audio.reader import SoundFileReader
from dance_core.data.features import audio_reader_for, load_audio
from dance_core.errors import DataError

OGGS = ["vibe_ace.ogg", "hungarian_dance_5.ogg", "sugar_plum_fairy.ogg", "lets_go_fishin.ogg"]


def test_soundfile_reader_wins_over_core_wav(registry, audio_dir):
    assert isinstance(audio_reader_for(audio_dir / "sample.wav", registry), SoundFileReader)
    assert isinstance(audio_reader_for(audio_dir / "vibe_ace.ogg", registry), SoundFileReader)


def test_wav_matches_core_reader(audio_dir, sample):
    from dance_core.formats.wav import WavReader

    core = WavReader().read(audio_dir / "sample.wav")
    assert sample.rate == core.rate == 44100
    assert sample.samples.dtype == np.float32 and sample.samples.ndim == 1
    np.testing.assert_allclose(sample.samples, core.samples, atol=1e-6)
    assert sample.duration == pytest.approx(2.8, abs=0.05)


@pytest.mark.parametrize("name", OGGS)
def test_every_ogg_fixture_loads(registry, audio_dir, name):
    audio = load_audio(audio_dir / name, registry)
    assert audio.duration > 30 and audio.rate in (22050, 44100)
    assert audio.samples.dtype == np.float32 and np.abs(audio.samples).max() <= 1.0
    assert audio.samples.std() > 0.01  # real music, not silence


@pytest.mark.parametrize("fmt,suffix,tol", [("FLAC", ".flac", 1e-4), ("MP3", ".mp3", 0.2), ("OGG", ".ogg", 0.2)])
def test_flac_mp3_ogg_round_trip(tmp_path, registry, sample, fmt, suffix, tol):
    stereo = np.stack([sample.samples, 0.5 * sample.samples], axis=1)
    path = tmp_path / f"song{suffix}"
    sf.write(path, stereo, sample.rate, format=fmt)
    audio = load_audio(path, registry)
    assert audio.rate == sample.rate
    assert abs(len(audio.samples) - len(sample.samples)) < 0.1 * sample.rate  # codecs may pad
    mono = 0.75 * sample.samples
    # lossy codecs delay the signal: compare after the best alignment
    n = len(mono) - 4096
    lags = range(0, 3000, 1)
    got = audio.samples
    best = min(lags, key=lambda k: np.mean((got[k : k + n] - mono[:n]) ** 2) if k + n <= len(got) else np.inf)
    err = np.sqrt(np.mean((got[best : best + n] - mono[:n]) ** 2)) / np.sqrt(np.mean(mono[:n] ** 2))
    assert err < tol


def test_missing_empty_folder_files(tmp_path, registry):
    reader = SoundFileReader()
    with pytest.raises(DataError, match=r"nope\.ogg: audio file not found"):
        reader.read(tmp_path / "nope.ogg")
    empty = tmp_path / "empty.mp3"
    empty.write_bytes(b"")
    with pytest.raises(DataError, match=r"empty\.mp3: audio file is empty"):
        reader.read(empty)
    with pytest.raises(DataError, match="is a folder"):
        reader.read(tmp_path)


@pytest.mark.parametrize("suffix", [".wav", ".ogg", ".mp3", ".flac"])
def test_corrupt_and_non_audio_files_are_one_line_errors(tmp_path, suffix):
    path = tmp_path / f"notes{suffix}"
    path.write_text("these are my notes, not music\n" * 20)
    with pytest.raises(DataError) as info:
        SoundFileReader().read(path)
    message = str(info.value)
    assert message.startswith(str(path)) and "cannot decode audio" in message and "\n" not in message


def test_truncated_ogg_is_an_error_or_shorter(tmp_path, audio_dir):
    data = (audio_dir / "vibe_ace.ogg").read_bytes()
    path = tmp_path / "cut.ogg"
    path.write_bytes(data[:200])  # header only, no audio pages
    with pytest.raises(DataError, match="cut.ogg"):
        SoundFileReader().read(path)


def test_silence_and_short_clips_warn_but_load(tmp_path):
    path = tmp_path / "quiet.wav"
    sf.write(path, np.zeros(22050 // 2, np.float32), 22050)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        audio = SoundFileReader().read(path)
    text = " ".join(str(w.message) for w in caught)
    assert "silent" in text and "0.50 s long" in text
    assert audio.duration == pytest.approx(0.5)


def test_audioread_fallback_decodes_when_libsndfile_cannot(monkeypatch, audio_dir, sample):
    import dance_audio.reader as reader

    def refuse(path):
        raise RuntimeError("Format not recognised.")

    monkeypatch.setattr(reader, "_read_soundfile", refuse)
    audio = SoundFileReader().read(audio_dir / "sample.wav")  # audioread's stdlib backend reads WAV
    assert audio.rate == sample.rate
    np.testing.assert_allclose(audio.samples, sample.samples, atol=1e-6)
