"""DanceRevolution's own setting: 2D OpenPose BODY_25 keypoints, read, learned and written back."""

import json

import numpy as np
import pytest

from dance_core.compose import compose
from dance_core.data.synthetic_beats import click_track
from dance_core.formats.wav import write_wav
from dance_core.motion.skeletons import BODY25_ORDER
from dance_core.recipe import load_recipe
from dance_core.train import Trainer

FPS, SECONDS = 20, 6.0


def write_pair(folder, name, bpm, rng):
    """A click track and a dancer whose keypoints sway and bounce with its beats (pixels, y down)."""
    beats = np.arange(0.25, SECONDS, 60 / bpm)
    write_wav(folder / f"{name}.wav", click_track(beats, SECONDS, 16000, rng), 16000)
    t = np.arange(int(SECONDS * FPS)) / FPS
    phase = 2 * np.pi * (t - 0.25) * bpm / 60
    rest = np.stack([np.linspace(500, 780, 25), np.linspace(200, 600, 25)], axis=-1)
    sway = 30 * np.sin(phase / 2)[:, None] * rng.uniform(0.5, 1.0, 25)[None]
    bounce = 15 * np.abs(np.sin(phase))[:, None] * np.ones(25)[None]
    xy = rest[None] + np.stack([sway, bounce], axis=-1)
    (folder / f"{name}.json").write_text(json.dumps({"fps": FPS, "keypoints": xy.tolist()}))


@pytest.mark.slow
def test_small_recipe_trains_on_body25_keypoints_and_writes_them(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    rng = np.random.default_rng(0)
    for i, bpm in enumerate((96, 108, 120, 132)):
        write_pair(data, f"clip{i}", bpm, rng)
    recipe = load_recipe(
        "dancerevolution-small",
        [
            "features.music=[{plugin: energy}]",
            f"data.dataset={{plugin: folder, path: {data}}}",
            "motion={plugin: positions, dims: 2}",
            "data.segment_frames=40",
            "data.val_fraction=0.25",
            "training.steps=40",
            "training.batch_size=8",
            "training.val_every=10000",
            "training.checkpoint_every=10000",
            "model.encoder.dim=32",
            "model.encoder.ff_dim=64",
            "model.head.hidden=64",
            "compose.formats=[keypoints]",
        ],
    )
    trainer = Trainer(recipe, tmp_path / "run", quiet=True)
    assert trainer.model.head.out.out_features == trainer.motion_info.dim >= 50  # 25 joints × (x, y) + root
    result = trainer.run()
    assert result.last_loss < result.first_loss
    paths = compose(
        recipe,
        music=[str(data / "clip0.wav")],
        checkpoint=str(result.checkpoint),
        out_dir=str(tmp_path / "out"),
        quiet=True,
    )
    written = json.loads(paths[0].read_text())
    keypoints = np.asarray(written["keypoints"])
    assert written["format"] == "BODY_25" and len(BODY25_ORDER) == 25
    assert keypoints.shape == (int(SECONDS * FPS), 25, 2) and np.isfinite(keypoints).all()
    # back in pixels at the trained body's size (root deltas: the start position itself is not kept)
    width = keypoints[..., 0].max(-1) - keypoints[..., 0].min(-1)
    height = keypoints[..., 1].max(-1) - keypoints[..., 1].min(-1)
    assert 150 < width.mean() < 450 and 250 < height.mean() < 550, (width.mean(), height.mean())
