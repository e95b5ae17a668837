from __future__ import annotations

import pickle

import numpy as np
import pytest

from dance_audio.madmom_compat import madmom_available
from dance_core.errors import PluginError
from dance_core.media import FeatureInputs

pytestmark = pytest.mark.skipif(not madmom_available(), reason="the madmom extra is not installed")


@pytest.fixture(scope="module")
def madmom():
    from dance_audio.madmom_compat import import_madmom

    return import_madmom()


@pytest.fixture(scope="module")
def sample_44k(sample):
    assert sample.rate == 44100
    return sample.samples


@pytest.fixture(scope="module")
def madmom_activations(madmom, sample_44k):
    from madmom.audio.signal import Signal
    from madmom.features.downbeats import RNNDownBeatProcessor

    return RNNDownBeatProcessor()(Signal(sample_44k, sample_rate=44100))


def test_compat_makes_madmom_import_on_numpy_2(madmom):
    import collections

    assert madmom.__version__ == "0.16.1"
    assert collections.MutableSequence is collections.abc.MutableSequence
    assert np.float is float and np.int is int


def test_our_network_input_equals_madmoms_preprocessing(madmom, sample_44k):
    from madmom.audio.signal import Signal
    from madmom.features.downbeats import RNNDownBeatProcessor

    from dance_audio.downbeat_features import downbeat_input

    ours = downbeat_input(sample_44k)
    theirs = RNNDownBeatProcessor().processors[0](Signal(sample_44k, sample_rate=44100))
    assert ours.shape == theirs.shape == (281, 314)
    np.testing.assert_allclose(ours, theirs, atol=1e-5)


def test_port_equals_madmom(sample_44k, madmom_activations):
    from dance_audio.downbeat_net import downbeat_activations

    ours = downbeat_activations(sample_44k)
    assert ours.shape == madmom_activations.shape == (281, 2)
    assert np.abs(ours - madmom_activations).max() < 1e-4
    assert madmom_activations.max() > 0.5  # real beats in real music, not a trivial match


def test_lstm_kernel_equals_a_float64_reference_over_a_long_sequence():
    """The cell state integrates the gates over thousands of steps: rounding must not add up."""
    from dance_audio.lstm_kernel import lstm_sequence

    rng = np.random.default_rng(1)
    steps, hidden = 3000, 25
    pre = (rng.standard_normal((steps, 4 * hidden)) * 4).astype(np.float32)
    pre[:, hidden : 2 * hidden] += 6.0  # forget gates near 1: long memory, large cell states
    w_rec = (rng.standard_normal((hidden, 4 * hidden)) * 0.3).astype(np.float32)
    peep = (rng.standard_normal((3, hidden)) * 0.3).astype(np.float32)
    out = np.zeros((steps, 2 * hidden), np.float32)
    lstm_sequence(pre, w_rec, peep, True, out[:, hidden:])  # a column block, read from the end

    def sigmoid(v):
        return 1.0 / (1.0 + np.exp(-v))

    h, c, ref = np.zeros(hidden), np.zeros(hidden), np.zeros((steps, hidden))
    for t in range(steps - 1, -1, -1):
        g = pre[t] + h @ w_rec
        i, f = sigmoid(g[:hidden] + c * peep[0]), sigmoid(g[hidden : 2 * hidden] + c * peep[1])
        c = c * f + np.tanh(g[2 * hidden : 3 * hidden]) * i
        h = np.tanh(c) * sigmoid(g[3 * hidden :] + c * peep[2])
        ref[t] = h
    assert np.abs(c).max() > 50  # the test reaches saturated, long-memory cells
    assert np.abs(out[:, hidden:] - ref).max() < 1e-4  # float32 gates would be off by ~2e-3 here
    assert not out[:, :hidden].any()  # the other block is untouched


def test_madmom_backend_and_fps_resampling(sample, madmom_activations):
    from dance_audio.downbeat import DownbeatFeatures, resample_activation

    inputs = FeatureInputs(n_frames=sample.n_frames(100.0), audio=sample)
    native = DownbeatFeatures("madmom").extract(inputs, 100.0)
    np.testing.assert_allclose(native, madmom_activations, atol=1e-6)
    inputs20 = FeatureInputs(n_frames=sample.n_frames(20.0), audio=sample)
    at20 = DownbeatFeatures("port").extract(inputs20, 20.0)
    assert at20.shape == (57, 2)
    np.testing.assert_allclose(at20, resample_activation(madmom_activations, 100.0, 57, 20.0), atol=1e-4)


def test_dbn_downbeat_tracker_runs_despite_the_ragged_array(madmom, madmom_activations):
    from madmom.features.downbeats import DBNDownBeatTrackingProcessor

    beats = DBNDownBeatTrackingProcessor(beats_per_bar=[3, 4], fps=100)(madmom_activations)
    assert beats.shape[1] == 2 and len(beats) >= 4


def test_restricted_unpickler_refuses_foreign_globals(tmp_path):
    from dance_audio.madmom_weights import _load

    path = tmp_path / "evil.pkl"
    path.write_bytes(pickle.dumps(print))
    with pytest.raises(pickle.UnpicklingError, match="builtins.print is not allowed"):
        _load(path)


def test_port_without_madmom_gives_an_install_hint(monkeypatch):
    import importlib.util

    from dance_audio.madmom_weights import load_downbeat_ensemble

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "madmom" else real(name, *a))
    with pytest.raises(PluginError, match="madmom is not installed"):
        load_downbeat_ensemble()


def test_missing_madmom_gives_an_install_hint(monkeypatch):
    import dance_audio.madmom_compat as compat

    monkeypatch.setattr(compat, "madmom_available", lambda: False)
    with pytest.raises(PluginError, match="pip install"):
        compat.import_madmom()
