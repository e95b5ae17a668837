from __future__ import annotations

import numpy as np
import pytest

from dance_audio.downbeat import resample_activation
from dance_audio.timing import event_phase, events_to_onehot, fit_frames, retime


def test_retime_interpolates_at_target_times():
    x = np.arange(10, dtype=np.float32)[:, None] * 2.0  # value 2*j at time j/10
    y = retime(x, 10.0, 7, 4.0)  # times 0, .25, .5, ...
    np.testing.assert_allclose(y[:, 0], [0, 5, 10, 15, 18, 18, 18])  # past the end holds the last value


def test_fit_frames_crops_and_pads_with_the_last_row():
    x = np.arange(6, dtype=np.float32).reshape(3, 2)
    assert fit_frames(x, 2).tolist() == [[0, 1], [2, 3]]
    assert fit_frames(x, 5)[3:].tolist() == [[4, 5], [4, 5]]


def test_onehot_marks_nearest_frames_and_drops_late_events():
    hot = events_to_onehot(np.array([0.0, 0.26, 0.74, 5.0]), 10, 4.0)
    assert np.nonzero(hot)[0].tolist() == [0, 1, 3]


def test_phase_rises_linearly_between_events_and_extrapolates():
    phase = event_phase(np.array([1.0, 2.0, 3.0]), 50, 10.0)
    assert phase[10] == pytest.approx(0.0) and phase[15] == pytest.approx(0.5)
    assert phase[5] == pytest.approx(0.5)  # before the first beat: the grid continues backwards
    assert phase[45] == pytest.approx(0.5)  # after the last beat: it continues forwards
    assert np.all((phase >= 0) & (phase < 1))
    assert np.all(event_phase(np.array([1.0]), 20, 10.0) == 0)


@pytest.mark.parametrize("peak_frame", [50, 51, 52, 53, 54])
def test_downsampled_activation_keeps_every_peak(peak_frame):
    act = np.zeros((300, 2), np.float32)
    act[peak_frame] = [0.9, 0.4]
    out = resample_activation(act, 100.0, 60, 20.0)
    assert out.shape == (60, 2)
    assert out.max(axis=0).tolist() == pytest.approx([0.9, 0.4])
    assert np.argmax(out[:, 0]) == round(peak_frame / 5)  # the target frame nearest its time


def test_upsampled_activation_interpolates():
    act = np.zeros((10, 2), np.float32)
    act[4] = 1.0
    out = resample_activation(act, 100.0, 30, 200.0)
    assert out[8, 0] == pytest.approx(1.0) and out[7, 0] == pytest.approx(0.5) and out[9, 0] == pytest.approx(0.5)
