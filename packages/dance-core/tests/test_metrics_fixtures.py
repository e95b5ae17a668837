"""Metrics on the real fixtures, read in place through the registered motion formats and FK."""

import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.evaluation.geometric import geometric_features
from dance_core.evaluation.loading import load_clips
from dance_core.evaluation.metrics import FeatureFID, Freezing, PhysicalFootContact
from dance_core.evaluation.music import read_beats_file
from dance_core.protocols import JointClip
from dance_core.registry import get_registry

FIXTURES = Path(__file__).resolve().parents[3] / ".." / "shared" / "fixtures"

sys.path.insert(0, str(Path(__file__).parent))
from smpl_model_helpers import smpl_model  # noqa: E402, F401 - fixture: a synthetic SMPL model in DANCE_SMPL_MODEL


def test_cmu_bvh_through_fk_gives_a_human_in_metres():
    (clip,) = load_clips(FIXTURES / "bvh", get_registry())
    assert clip.name == "cmu_01_01" and clip.positions.shape == (2752, 31, 3) and clip.fps == 120.0
    height = np.ptp(clip.positions[0, :, 1])
    assert 1.0 < height < 2.5  # the file's units were inferred from the body's size
    assert Freezing()([clip]).values["PFF"] < 50.0  # a person walking is not frozen
    assert PhysicalFootContact()([clip]).values["PFC"] > 0.0  # feet found by name (LeftFoot, ...)


@pytest.mark.usefixtures("smpl_model")
def test_smpl_sample_has_geometric_features_and_zero_self_distance():
    (clip,) = load_clips(FIXTURES / "smpl", get_registry())
    assert clip.positions.shape == (127, 24, 3) and clip.fps == 60.0
    g = geometric_features(clip)
    assert g.shape == (32,) and np.all((g >= 0) & (g <= 1)) and 0 < g.sum() < 32
    halves = [JointClip(f"h{k}", clip.positions[k * 60 : k * 60 + 60], 60.0, clip.joints) for k in (0, 1)]
    assert FeatureFID("geometric")(halves, halves).values["FID_g"] == pytest.approx(0.0, abs=1e-6)
    assert FeatureFID("geometric")(halves, halves[::-1]).values["FID_g"] == pytest.approx(0.0, abs=1e-6)


def test_madmom_beat_annotation_reads_the_times():
    beats = read_beats_file(FIXTURES / "audio" / "sample.beats")
    np.testing.assert_allclose(beats, [0.0913, 0.7997, 1.4806, 2.1478], atol=1e-4)
