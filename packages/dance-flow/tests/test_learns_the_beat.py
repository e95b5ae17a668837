"""A short training run of the default recipe learns to dance on the beat (not merely to move)."""

from __future__ import annotations

import numpy as np
import pytest

from dance_core.compose import compose
from dance_core.evaluation.quality import beat_locking
from dance_core.formats.bvh import BvhFormat
from dance_core.formats.wav import write_wav
from dance_core.recipe import load_recipe
from dance_core.synth.synthetic_dance import make_clip
from dance_core.train import train

SHORT = [
    "training.steps=500",
    "training.batch_size=32",
    "training.val_every=100000",
    "training.checkpoint_every=500",
    "training.lr_schedule.warmup=50",
    "data.dataset.songs=12",
    "data.dataset.seconds=20",
    "data.dataset.dances_per_song=1",
    "data.mirror=false",
    "compose.temperature=0",
    "compose.formats=[bvh]",
    "compose.beat_align=false",  # what the model learned, not compose's time warp onto the beats
]


@pytest.mark.slow
def test_a_short_run_of_the_default_recipe_locks_to_the_beat(tmp_path):
    recipe = load_recipe("default", SHORT)
    checkpoint = train(recipe, out=str(tmp_path / "run"), quiet=True).checkpoint
    scores = []
    for i in range(2):  # held-out songs: another seed, so other music and other dances
        clip = make_clip(i, seed=123, seconds=30, bpm=(80, 140), rate=22050, fps=20, tracker="librosa")
        song = tmp_path / f"held{i}.wav"
        write_wav(song, clip.audio.samples, clip.audio.rate)
        (path,) = compose(recipe, music=[str(song)], checkpoint=str(checkpoint), out_dir=str(tmp_path), quiet=True)
        motion = BvhFormat().read(str(path)).skeleton_motion
        scores.append(beat_locking(motion.positions(), motion.fps, np.asarray(clip.meta["beats"])))
    locking = np.mean([s["locking_hips"] for s in scores])
    control = np.mean([s["control_hips"] for s in scores])
    assert locking >= 0.5 and locking >= 3 * control, scores
