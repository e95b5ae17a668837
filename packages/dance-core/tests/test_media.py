import math
import struct

import numpy as np
import pytest

from dance_core.atomic import atomic_path, write_text
from dance_core.components.configs import CosineConfig, MultiStepConfig
from dance_core.components.energy import EnergyFeatures
from dance_core.components.schedules import build_cosine, build_multistep
from dance_core.data.synthetic_beats import click_track
from dance_core.errors import DataError
from dance_core.formats.wav import WavReader, write_wav
from dance_core.media import Audio, FeatureInputs, frame_count


def test_frame_count_rule():
    assert frame_count(2.0, 20) == 40
    assert frame_count(2.01, 20) == 41
    assert frame_count(0.1 * 3, 10) == 3  # float noise does not add a frame


@pytest.mark.parametrize("bits,fmt", [(8, 1), (16, 1), (24, 1), (32, 1), (32, 3)])
def test_wav_reader_decodes_every_encoding(tmp_path, bits, fmt):
    rate, x = 8000, np.sin(np.linspace(0, 20, 800)) * 0.5
    stereo = np.stack([x, -x * 0.5], axis=1)
    if fmt == 3:
        raw = stereo.astype("<f4").tobytes()
    elif bits == 8:
        raw = (stereo * 127 + 128).astype(np.uint8).tobytes()
    elif bits == 24:
        v = (stereo * (2**23 - 1)).astype("<i4").reshape(-1)
        raw = b"".join(int(s).to_bytes(3, "little", signed=True) for s in v)
    else:
        raw = (stereo * (2 ** (bits - 1) - 1)).astype(f"<i{bits // 8}").tobytes()
    block = 2 * bits // 8
    body = b"WAVE" + b"fmt " + struct.pack("<IHHIIHH", 16, fmt, 2, rate, rate * block, block, bits)
    body += b"LIST" + struct.pack("<I", 3) + b"abc\x00"  # an odd-sized chunk to skip
    body += b"data" + struct.pack("<I", len(raw)) + raw
    (tmp_path / "a.wav").write_bytes(b"RIFF" + struct.pack("<I", len(body)) + body)
    audio = WavReader().read(tmp_path / "a.wav")
    assert audio.rate == rate and audio.samples.dtype == np.float32
    np.testing.assert_allclose(audio.samples, (x - 0.5 * x) / 2, atol=2 / 2 ** (bits - 1) + 1e-6)


def test_wav_write_read_round_trip_and_errors(tmp_path):
    x = (np.random.default_rng(0).uniform(-0.9, 0.9, 1000)).astype(np.float32)
    write_wav(tmp_path / "r.wav", x, 22050)
    audio = WavReader().read(tmp_path / "r.wav")
    np.testing.assert_allclose(audio.samples, x, atol=1 / 32767)
    (tmp_path / "trunc.wav").write_bytes((tmp_path / "r.wav").read_bytes()[:30])
    with pytest.raises(DataError, match="corrupt WAV"):
        WavReader().read(tmp_path / "trunc.wav")


def test_energy_features_shape_alignment_and_onsets():
    rate, fps, seconds, bpm = 16000, 20, 6.0, 120
    beats = np.arange(0.25, seconds, 60 / bpm)
    audio = Audio(click_track(beats, seconds, rate, np.random.default_rng(1)), rate)
    ext = EnergyFeatures(1024, [200.0, 2000.0], 1e-6)
    feats = ext.extract(FeatureInputs(audio.n_frames(fps), audio), fps)
    assert feats.shape == (120, ext.dim()) == (120, 4) and np.isfinite(feats).all()
    onset = feats[:, -1]
    peaks = [
        i
        for i in range(1, len(onset) - 1)
        if onset[i] > onset[i - 1] and onset[i] >= onset[i + 1] and onset[i] > 0.5 * onset.max()
    ]
    expected = np.round(beats * fps).astype(int)
    assert len(peaks) == len(expected)
    assert np.max(np.abs(np.array(peaks) - expected)) <= 1  # within one frame of each click


def test_schedules():
    cos = build_cosine(CosineConfig(warmup=10, floor=0.1))
    assert cos(0, 0, 110) == pytest.approx(0.1) and cos(9, 0, 110) == pytest.approx(1.0)
    assert cos(60, 0, 110) == pytest.approx(0.55) and cos(110, 0, 110) == pytest.approx(0.1)
    step = build_multistep(MultiStepConfig(milestones=[200, 400], gamma=0.1))
    assert [step(s, 0, 600) for s in (0, 199, 200, 450)] == pytest.approx([1, 1, 0.1, 0.01])


def test_atomic_write_keeps_the_old_file_on_failure(tmp_path):
    target = tmp_path / "out.txt"
    write_text(target, "old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("crash")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]
    assert math.isclose(target.stat().st_mode & 0o777 & 0o644, 0o644)
