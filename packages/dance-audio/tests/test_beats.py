from __future__ import annotations

import numpy as np
import pytest

from dance_audio.beats import BeatFeatures, track_beats
from dance_audio.madmom_compat import madmom_available
from dance_core.media import FeatureInputs


def f_measure(detections, annotations, window=0.07):
    """Beat F-measure: one-to-one matches within +-window seconds."""
    detections, annotations = list(np.sort(detections)), list(np.sort(annotations))
    hits = 0
    for a in annotations:
        close = [d for d in detections if abs(d - a) <= window]
        if close:
            detections.remove(min(close, key=lambda d: abs(d - a)))
            hits += 1
    n_det = hits + len(detections)
    if hits == 0:
        return 0.0
    precision, recall = hits / n_det, hits / len(annotations)
    return 2 * precision * recall / (precision + recall)


def test_f_measure_helper():
    assert f_measure([1.0, 2.0], [1.05, 2.0]) == 1.0
    assert f_measure([1.0, 1.5, 2.0], [1.0, 2.0]) == pytest.approx(0.8)
    assert f_measure([1.1], [1.0]) == 0.0


def test_beats_on_sample_match_hand_annotations(sample, annotated_beats):
    if not madmom_available():
        pytest.skip("the madmom extra is not installed")
    times, positions = annotated_beats
    beats = track_beats(sample, "madmom")  # madmom's DBN on the ported RNN (opt-in)
    assert f_measure(beats.times, times) >= 0.9
    assert f_measure(beats.downbeats, times[positions == 1]) == 1.0


@pytest.mark.parametrize("tracker", ["auto", "flux", "librosa"])
def test_licence_clean_trackers_on_a_click_track(make_clicks, monkeypatch, tracker):
    import dance_audio.beats as beats_module
    import dance_audio.madmom_compat as compat

    monkeypatch.setattr(compat, "madmom_available", lambda: False)  # as without the madmom extra
    if tracker == "auto":  # without madmom, auto is the default tracker
        monkeypatch.setattr(beats_module, "track_librosa", lambda *_: pytest.fail("auto fell back to librosa"))
    clicks = np.arange(0.5, 9.6, 0.5)  # 120 BPM
    beats = track_beats(make_clicks(clicks, 10.0), tracker)
    assert f_measure(beats.times, clicks) >= 0.9
    assert set(beats.positions.tolist()) <= {1, 2, 3, 4}
    assert np.count_nonzero(beats.positions == 1) in (len(clicks) // 4, len(clicks) // 4 + 1)


def test_librosa_fallback_equals_librosas_own_tracker_on_real_music(sample, librosa):
    from dance_audio.beats import LIBROSA_HOP, LIBROSA_RATE, track_librosa
    from dance_audio.timing import resample

    ours = track_librosa(sample, [3, 4], 55.0, 160.0)
    y = resample(sample.samples, sample.rate, LIBROSA_RATE)
    onset = librosa.onset.onset_strength(y=y, sr=LIBROSA_RATE, hop_length=LIBROSA_HOP)
    _, frames = librosa.beat.beat_track(
        onset_envelope=onset, sr=LIBROSA_RATE, hop_length=LIBROSA_HOP, start_bpm=float(np.sqrt(55.0 * 160.0))
    )
    assert len(frames) >= 4
    np.testing.assert_allclose(ours.times, np.asarray(frames) * LIBROSA_HOP / LIBROSA_RATE, atol=1e-9)


def test_beat_features_mark_beats_and_phases(sample, annotated_beats):
    if not madmom_available():
        pytest.skip("the madmom extra is not installed")
    fps = 30.0
    inputs = FeatureInputs(n_frames=sample.n_frames(fps), audio=sample)
    feats = BeatFeatures("auto", [3, 4], 55.0, 160.0).extract(inputs, fps)
    assert feats.shape == (85, 6) and feats.dtype == np.float32
    times, _ = annotated_beats
    beat_frames = np.nonzero(feats[:, 0])[0]
    assert np.all(np.abs(beat_frames / fps - times) <= 2 / fps)
    assert np.nonzero(feats[:, 1])[0].tolist() == [beat_frames[0]]  # one downbeat: the first beat
    np.testing.assert_allclose(feats[:, 2] ** 2 + feats[:, 3] ** 2, 1.0, atol=1e-5)
    # on a beat frame the beat phase is close to 0 (sin ~ 0, cos ~ 1)
    assert np.all(feats[beat_frames, 3] > 0.9)


def test_downbeat_and_beat_features_on_clicks_at_known_times(make_clicks):
    if not madmom_available():
        pytest.skip("the madmom extra is not installed")
    from dance_audio.downbeat import DownbeatFeatures

    fps = 30.0
    clicks = np.arange(1.0, 11.5, 0.5)  # 120 BPM
    audio = make_clicks(clicks, 12.0)
    inputs = FeatureInputs(n_frames=audio.n_frames(fps), audio=audio)
    act = DownbeatFeatures().extract(inputs, fps)
    assert act.shape == (360, 2) and np.all((act >= 0) & (act <= 1))
    beat_or_downbeat = act.sum(axis=1)
    for t in clicks[2:-2]:  # each click is a local activation peak within a frame of its time
        f = int(round(t * fps))
        assert abs(int(np.argmax(beat_or_downbeat[f - 5 : f + 6])) - 5) <= 1
    beats = track_beats(audio, "madmom")
    assert f_measure(beats.times, clicks) >= 0.9


def test_the_default_tracker_reads_no_madmom_file(make_clicks, monkeypatch):
    """madmom's weights are non-commercial: only ``madmom`` or ``auto``, asked for by name, read them."""
    import dance_audio.beats as beats_module
    from dance_audio.configs import BeatsConfig

    assert BeatsConfig().tracker == "flux"

    def no_madmom(*_):
        raise AssertionError("madmom's files were read")

    monkeypatch.setattr(beats_module, "track_madmom", no_madmom)
    audio = make_clicks(np.arange(0.5, 5.6, 0.5), 6.0)
    assert len(track_beats(audio).times) >= 4
    inputs = FeatureInputs(n_frames=audio.n_frames(30.0), audio=audio)
    assert beats_module.build(BeatsConfig()).extract(inputs, 30.0).shape == (180, 6)
    with pytest.raises(AssertionError, match="madmom's files"):
        track_beats(audio, "madmom")
