import numpy as np
import pytest

from dance_core.data.sampling import SegmentSampler, split_clips
from dance_core.data.sources import Clip
from dance_core.errors import DataError


def clip(name, n=30, song=""):
    return Clip(name, np.full((n, 2), len(name), np.float32), {"music": np.zeros((n, 1), np.float32)}, song)


def test_split_keeps_every_clip_of_a_song_on_one_side():
    clips = [clip(f"s{i}") for i in range(6)] + [clip(f"s{i}-mirrored", song=f"s{i}") for i in range(6)]
    for seed in range(10):
        train, val = split_clips(clips, 0.34, seed)
        assert len(train) + len(val) == 12 and len(val) == 4
        assert not {c.song for c in train} & {c.song for c in val}
    assert split_clips(clips, 0.34, 3) == split_clips(clips, 0.34, 3)
    assert split_clips([clip("only")], 0.5, 0)[1] == []


def test_segment_batches_depend_only_on_seed_and_index():
    sampler = SegmentSampler([clip("a", 40), clip("bb", 12), clip("ccc", 5)], 10, 6, seed=3)
    assert sampler.windows() == 31 + 3  # the 5-frame clip is too short
    m1, s1 = sampler.batch(7)
    m2, _ = sampler.batch(7)
    m3, _ = sampler.batch(8)
    assert m1.shape == (6, 10, 2) and s1["music"].shape == (6, 10, 1)
    assert np.array_equal(m1, m2) and not np.array_equal(m1, m3)
    with pytest.raises(DataError, match="longest has 5"):
        SegmentSampler([clip("x", 5)], 10, 2, seed=0)
