from __future__ import annotations

import math

import numpy as np
import pytest

from dance_audio.librosa438 import Librosa438
from dance_audio.spectral import MelFeatures, OnsetFeatures
from dance_core.media import FeatureInputs, frame_count

CLICKS = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]
SECONDS = 4.02


def _inputs(audio, fps):
    return FeatureInputs(n_frames=frame_count(audio.duration, fps), audio=audio)


@pytest.mark.parametrize("fps", [20.0, 24.0, 30.0, 60.0])
def test_mel_and_onset_shapes_and_click_alignment(fps, make_clicks):
    audio = make_clicks(CLICKS, SECONDS)
    inputs = _inputs(audio, fps)
    assert inputs.n_frames == math.ceil(SECONDS * fps)
    mel = MelFeatures(80, 22050, 2048, 0.0, None, "one").extract(inputs, fps)
    onset = OnsetFeatures(80, 22050, 2048).extract(inputs, fps)
    assert mel.shape == (inputs.n_frames, 80) and onset.shape == (inputs.n_frames, 1)
    assert mel.dtype == np.float32 and np.all(np.isfinite(mel))
    # each click raises the onset curve within a frame of the click's time (a 2048 window centred on it)
    peaks = [int(np.argmax(onset[int(round(t * fps)) - 3 : int(round(t * fps)) + 4, 0])) - 3 for t in CLICKS]
    assert all(-2 <= p <= 1 for p in peaks), peaks
    # the 2 kHz band is loud at a click frame and quiet between clicks
    band = int(np.argmax(mel[int(round(0.5 * fps)) + 1]))
    hot = mel[[int(round(t * fps)) + 1 for t in CLICKS], band]
    cold = mel[[int(round((t + 0.25) * fps)) for t in CLICKS], band]
    assert np.min(hot) > np.max(cold) + 20  # dB


def test_mel_reference_max_is_zero_at_the_loudest_bin(make_clicks):
    audio = make_clicks(CLICKS, SECONDS)
    mel = MelFeatures(80, 22050, 2048, 0.0, None, "max").extract(_inputs(audio, 30.0), 30.0)
    assert mel.max() == pytest.approx(0.0)


def test_librosa_438_shape_alignment_and_beat_column(make_clicks):
    fps = 30.0
    audio = make_clicks(CLICKS, SECONDS)
    extractor = Librosa438()
    assert extractor.dim() == 438 and extractor.rate(fps) == 15360
    feats = extractor.extract(_inputs(audio, fps), fps)
    assert feats.shape == (math.ceil(SECONDS * fps), 438) and feats.dtype == np.float32
    assert np.all(np.isfinite(feats))
    onset, beat = feats[:, 52], feats[:, 53]
    click_frames = np.array([round(t * fps) for t in CLICKS])
    # onset strength (column 52) peaks within a frame of each click
    for f in click_frames:
        assert abs(int(np.argmax(onset[f - 4 : f + 5])) - 4) <= 1
    # the beat one-hot (column 53, as Bailando's BAS reads it) marks clicks, within a frame
    beat_frames = np.nonzero(beat)[0]
    assert set(np.unique(beat)) <= {0.0, 1.0} and len(beat_frames) >= 4
    assert all(np.min(np.abs(click_frames - b)) <= 1 for b in beat_frames)
    # the tempogram (last 384 columns) is librosa's: normalized autocorrelation, lag 0 == 1 where active
    assert feats[60, 54] == pytest.approx(1.0, abs=1e-5)


def test_librosa_438_on_silence_is_finite(recwarn):
    from dance_core.media import Audio

    audio = Audio(np.zeros(22050, np.float32), 22050)
    feats = Librosa438().extract(_inputs(audio, 30.0), 30.0)
    assert feats.shape == (30, 438) and np.all(np.isfinite(feats))
    assert feats[:, 53].sum() == 0  # no beats in silence


def test_librosa_438_rejects_fractional_rates():
    from dance_core.errors import DataError

    with pytest.raises(DataError, match="not a whole sample rate"):
        Librosa438(hop_length=512).rate(29.97)


@pytest.mark.parametrize("rate,n_fft,n_mels,fmin,fmax", [(22050, 2048, 80, 0.0, None), (44100, 1024, 40, 30.0, 8000.0)])
def test_mel_filterbank_equals_librosa(rate, n_fft, n_mels, fmin, fmax, librosa):
    from dance_audio.spectral import mel_filterbank

    ours = mel_filterbank(rate, n_fft, n_mels, fmin, fmax)
    theirs = librosa.filters.mel(sr=rate, n_fft=n_fft, n_mels=n_mels, fmin=fmin, fmax=fmax)
    np.testing.assert_allclose(ours, theirs, rtol=1e-5, atol=1e-8)


def test_librosa_438_equals_the_reference_recipe_on_real_music(sample, librosa):
    """The DanceRevolution extractor's librosa calls, with librosa's defaults, at 15360 Hz (30 fps),
    against our librosa-free implementation: block by block (tolerances relative to each block's
    largest value), and the same beat frames."""
    from dance_audio.timing import resample

    sr = 15360
    y = resample(sample.samples, sample.rate, sr)
    mfcc = librosa.feature.mfcc(S=librosa.power_to_db(librosa.feature.melspectrogram(y=y, sr=sr), ref=np.max))
    delta = librosa.feature.delta(mfcc, width=3)
    harmonic, percussive = librosa.effects.hpss(y)
    chroma = librosa.feature.chroma_cqt(y=harmonic, sr=sr, n_chroma=12)
    onset = librosa.onset.onset_strength(y=percussive, aggregate=np.median, sr=sr)
    _, beats = librosa.beat.beat_track(onset_envelope=onset, sr=sr)
    beat = np.zeros_like(onset)
    beat[beats] = 1.0
    tempogram = librosa.feature.tempogram(onset_envelope=onset, sr=sr, win_length=384)
    reference = np.concatenate([mfcc, delta, chroma, onset[None], beat[None], tempogram], axis=0).T

    n = sample.n_frames(30.0)
    ours = Librosa438().extract(FeatureInputs(n_frames=n, audio=sample), 30.0)
    assert ours.shape == (n, 438) and len(reference) >= n
    reference = reference[:n]
    blocks = {"mfcc": (0, 20, 1e-5), "delta": (20, 40, 1e-5), "chroma": (40, 52, 1e-5), "onset": (52, 53, 1e-4)}
    for name, (lo, hi, tolerance) in {**blocks, "tempogram": (54, 438, 1e-4)}.items():
        error = np.max(np.abs(ours[:, lo:hi] - reference[:, lo:hi])) / np.max(np.abs(reference[:, lo:hi]))
        assert error < tolerance, (name, error)
    np.testing.assert_array_equal(ours[:, 53], reference[:, 53])  # the same beat frames
    np.testing.assert_allclose(ours, reference, rtol=1e-4, atol=1e-4)
    assert ours[:, 53].sum() >= 3  # real beats were found


def test_librosa_438_on_a_clip_shorter_than_a_window_is_finite():
    from dance_core.media import Audio

    rng = np.random.default_rng(1)
    audio = Audio((0.1 * rng.standard_normal(1000)).astype(np.float32), 22050)  # 45 ms
    feats = Librosa438().extract(_inputs(audio, 30.0), 30.0)
    assert feats.shape == (2, 438) and np.all(np.isfinite(feats))
