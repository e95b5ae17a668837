"""Each piece of the librosa-free ``librosa-438`` pipeline against librosa 0.11 on real music.

Spectrograms are frames first here and ``(bins, frames)`` in librosa, hence the transposes. Figures
reached on the first 30 s of vibe_ace.ogg at 15360 Hz (30 fps), asserted with some headroom
(errors over the reference's largest value): STFT ~1e-7, ISTFT ~3e-7, MFCC ~2e-7, deltas ~1e-6,
harmonic part ~3e-7, onset strength ~1e-5, tempogram ~4e-6 (float32 output; bit-exact in float64 on
the same envelope); chroma within ~1e-6 absolute after the per-frame max normalisation; HPSS masks,
spectral peaks, tuning, tempo and beat frames identical.
"""

from __future__ import annotations

import numpy as np
import pytest

from dance_audio import cepstrum, cqt, hpss, rhythm, spectral, stft, tuning
from dance_audio.timing import resample

SR, HOP, N_FFT = 15360, 512, 2048


def _rel(ours, theirs) -> float:
    """Largest absolute difference over the largest absolute reference value."""
    ours, theirs = np.asarray(ours, np.complex128), np.asarray(theirs, np.complex128)
    return float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs)))


@pytest.fixture(scope="module")
def song(audio_dir, registry):
    """30 s of real music at the analysis rate, and our pipeline's intermediate results on it."""
    from dance_core.data.features import load_audio

    audio = load_audio(audio_dir / "vibe_ace.ogg", registry)
    y = resample(audio.samples[: 30 * audio.rate], audio.rate, SR)
    spec = stft.stft(y, N_FFT, HOP)
    harmonic_mask, _ = hpss.hpss_masks(np.abs(spec), percussive=False)
    harmonic = stft.istft(spec * harmonic_mask, HOP, len(y))
    harmonic_spec = stft.stft(harmonic, N_FFT, HOP)
    basis = spectral.mel_filterbank(SR, N_FFT, 128).T
    db = spectral.power_to_db(np.abs(spec - harmonic_spec) ** 2 @ basis, top_db=80.0)
    return {
        "y": y,
        "spec": spec,
        "harmonic": harmonic,
        "harmonic_spec": harmonic_spec,
        "onset": rhythm.onset_strength(db, N_FFT, HOP),
    }


@pytest.fixture(scope="module")
def reference(librosa, song):
    """librosa's own calls on the same audio (the DanceRevolution recipe, step by step)."""
    y = song["y"]
    D = librosa.stft(y)
    harm, perc = librosa.decompose.hpss(D)
    harmonic = librosa.istft(harm, length=len(y))
    percussive = librosa.istft(perc, length=len(y))
    mel = librosa.feature.melspectrogram(y=y, sr=SR)
    mfcc = librosa.feature.mfcc(S=librosa.power_to_db(mel, ref=np.max))
    onset = librosa.onset.onset_strength(y=percussive, sr=SR, aggregate=np.median)
    return {
        "D": D,
        "harmonic": harmonic,
        "mfcc": mfcc,
        "delta": librosa.feature.delta(mfcc, width=3),
        "tuning": librosa.estimate_tuning(y=harmonic, sr=SR, bins_per_octave=36),
        "chroma": librosa.feature.chroma_cqt(y=harmonic, sr=SR, n_chroma=12),
        "onset": onset,
        "beats": librosa.beat.beat_track(onset_envelope=onset, sr=SR)[1],
        "tempogram": librosa.feature.tempogram(onset_envelope=onset, sr=SR, win_length=384),
    }


def test_stft_and_istft_match_librosa(librosa, song, reference):
    y, spec = song["y"], song["spec"]
    assert spec.shape == reference["D"].T.shape and spec.dtype == np.complex64
    assert _rel(spec.T, reference["D"]) < 1e-6  # float32 FFTs where librosa's are float64
    back = stft.istft(spec, HOP, len(y))
    assert back.dtype == np.float32 and len(back) == len(y)
    assert _rel(back, librosa.istft(reference["D"], length=len(y))) < 1e-6
    assert _rel(back, y) < 1e-6  # perfect reconstruction
    for length in (len(y) - 700, len(y) + 900):  # cropped, and zero padded past the last frame
        assert _rel(stft.istft(spec, HOP, length), librosa.istft(reference["D"], length=length)) < 1e-6


def test_mfcc_and_delta_match_librosa(song, reference):
    power = np.abs(song["spec"]) ** 2 @ spectral.mel_filterbank(SR, N_FFT, 128).T
    ours = cepstrum.mfcc(spectral.power_to_db(power, ref=power.max(), top_db=80.0), 20)
    assert _rel(ours.T, reference["mfcc"]) < 1e-5
    assert _rel(cepstrum.delta(ours, 3).T, reference["delta"]) < 1e-5
    assert _rel(cepstrum.delta(reference["mfcc"].T, 3).T, reference["delta"]) < 1e-6


@pytest.mark.parametrize("frames", [None, 5, 40])
def test_hpss_masks_equal_librosas(librosa, song, reference, frames):
    """Bit-identical masks on the same magnitudes, also on clips shorter than the median window."""
    D = reference["D"] if frames is None else reference["D"][:, 500 : 500 + frames]
    harm, perc = librosa.decompose.hpss(D, mask=True)
    ours_harm, ours_perc = hpss.hpss_masks(np.abs(D).T)
    np.testing.assert_array_equal(ours_harm.T, harm)
    np.testing.assert_array_equal(ours_perc.T, perc)


def test_hpss_masks_split_silence_evenly():
    harm, perc = hpss.hpss_masks(np.zeros((7, 33), np.float32))
    assert np.all(harm == 0.5) and np.all(perc == 0.5)


def test_harmonic_part_matches_librosa(song, reference):
    assert _rel(song["harmonic"], reference["harmonic"]) < 1e-5


def test_spectral_peaks_and_tuning_match_librosa(librosa, song, reference):
    magnitude = np.abs(librosa.stft(reference["harmonic"]))
    pitches, mags = librosa.piptrack(S=magnitude, sr=SR)
    ours_pitches, ours_mags = tuning.spectral_peaks(magnitude.T, SR, N_FFT)
    found = pitches > 0
    np.testing.assert_array_equal(np.sort(ours_pitches), np.sort(pitches[found]))
    np.testing.assert_array_equal(np.sort(ours_mags), np.sort(mags[found]))
    expected = reference["tuning"]
    assert tuning.estimate_tuning(magnitude.T, SR, N_FFT, bins_per_octave=36) == expected
    # and on our own harmonic part
    assert tuning.estimate_tuning(np.abs(song["harmonic_spec"]), SR, N_FFT, bins_per_octave=36) == expected


def test_tuning_of_silence_is_zero():
    assert tuning.estimate_tuning(np.zeros((10, 1025), np.float32), SR, N_FFT, bins_per_octave=36) == 0.0


def test_constant_q_and_chroma_match_librosa(librosa, song, reference):
    harmonic, tuned = reference["harmonic"], reference["tuning"]
    fmin = cqt.C1 * 2.0 ** (tuned / 36)
    theirs = np.abs(librosa.cqt(harmonic, sr=SR, n_bins=252, bins_per_octave=36, tuning=tuned))
    ours = cqt.cqt_magnitude(harmonic, SR, HOP, fmin, 252, 36)
    assert ours.shape == theirs.T.shape and _rel(ours.T, theirs) < 1e-5
    np.testing.assert_array_equal(cqt.chroma_map(252, 36, 12), librosa.filters.cq_to_chroma(252, bins_per_octave=36))
    # chroma after the per-frame max normalisation: same input, then our whole harmonic path
    assert np.max(np.abs(cqt.chroma_cqt(harmonic, SR, HOP, tuned, 7).T - reference["chroma"])) < 1e-5
    ours_tuning = tuning.estimate_tuning(np.abs(song["harmonic_spec"]), SR, N_FFT, bins_per_octave=36)
    assert np.max(np.abs(cqt.chroma_cqt(song["harmonic"], SR, HOP, ours_tuning, 7).T - reference["chroma"])) < 1e-5


def test_constant_q_with_early_downsampling_matches_librosa(librosa, song):
    """At 44.1 kHz with a hop of 1024 librosa first decimates the signal: so do we."""
    y = resample(song["y"][: 10 * SR], SR, 44100)
    assert cqt._early_downsampling(44100, 4125.0, 1024, 7) > 0
    theirs = np.abs(librosa.cqt(y, sr=44100, hop_length=1024, n_bins=252, bins_per_octave=36))
    assert _rel(cqt.cqt_magnitude(y, 44100, 1024, cqt.C1, 252, 36).T, theirs) < 1e-5


def test_onset_strength_matches_librosa(librosa, song, reference):
    ours = song["onset"]
    assert ours.shape == reference["onset"].shape and ours.dtype == np.float32
    assert _rel(ours, reference["onset"]) < 1e-4  # percussive STFT as STFT(y) - STFT(harmonic)
    # on the same percussive signal the flux itself is exact up to float32 FFT rounding
    percussive = librosa.istft(librosa.decompose.hpss(reference["D"])[1], length=len(song["y"]))
    db = spectral.power_to_db(
        np.abs(stft.stft(percussive, N_FFT, HOP)) ** 2 @ spectral.mel_filterbank(SR, N_FFT, 128).T, top_db=80.0
    )
    assert _rel(rhythm.onset_strength(db, N_FFT, HOP), reference["onset"]) < 1e-5


def test_tempogram_matches_librosa(song, reference):
    onset = reference["onset"]
    np.testing.assert_array_equal(rhythm.tempogram(onset, 384).T, reference["tempogram"])
    assert np.max(np.abs(rhythm.tempogram(onset, 384, np.float32).T - reference["tempogram"])) < 1e-6
    assert _rel(rhythm.tempogram(song["onset"], 384, np.float32).T, reference["tempogram"]) < 1e-4


def test_tempo_matches_librosa(librosa, reference):
    onset = reference["onset"]
    theirs = librosa.feature.tempogram(onset_envelope=onset, sr=SR, win_length=240).mean(axis=1)
    assert _rel(rhythm.mean_tempogram(onset, 240), theirs) < 1e-12
    for start in (60.0, 120.0, 150.0):
        expected = librosa.feature.tempo(onset_envelope=onset, sr=SR, start_bpm=start)[0]
        assert rhythm.estimate_tempo(onset, SR / HOP, start) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(
    "bpm,tightness,trim", [(None, 100, True), (None, 100, False), (90, 10, True), (200, 400, True)]
)
def test_beat_track_equals_librosas(librosa, reference, bpm, tightness, trim):
    onset = reference["onset"]
    tempo, beats = rhythm.beat_track(onset, SR / HOP, bpm=bpm, tightness=tightness, trim=trim)
    their_tempo, their_beats = librosa.beat.beat_track(
        onset_envelope=onset, sr=SR, bpm=bpm, tightness=tightness, trim=trim
    )
    assert tempo == pytest.approx(float(np.atleast_1d(their_tempo)[0]), rel=1e-12)
    np.testing.assert_array_equal(beats, their_beats)


def test_beat_track_on_our_onsets_finds_librosas_beats(song, reference):
    _, beats = rhythm.beat_track(song["onset"], SR / HOP)
    np.testing.assert_array_equal(beats, reference["beats"])
    assert len(beats) > 20


def test_beat_track_without_onsets_finds_nothing():
    tempo, beats = rhythm.beat_track(np.zeros(300, np.float32), 30.0)
    assert tempo == 0.0 and len(beats) == 0
