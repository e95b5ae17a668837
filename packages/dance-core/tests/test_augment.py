import pytest
import torch

from dance_core.errors import RecipeError
from dance_core.model import frame_dropout, motion_noise
from dance_core.protocols import TrainContext
from dance_core.recipe import load_recipe
from dance_core.recipe.schema import AugmentSpec
from dance_core.train import Trainer


def test_frame_dropout_zeroes_whole_frames_at_the_rate():
    x = torch.ones(64, 200, 5)
    y = frame_dropout(x, 0.3, torch.Generator().manual_seed(0))
    dropped = (y == 0).all(-1)
    assert ((y == 0) | (y == 1)).all() and torch.equal((y == 0).any(-1), dropped)  # frames, not channels
    assert abs(dropped.float().mean().item() - 0.3) < 0.01
    assert torch.equal(frame_dropout(x, 0.0), x)
    again = frame_dropout(x, 0.3, torch.Generator().manual_seed(0))
    assert torch.equal(y, again)


def test_motion_noise_scale_varies_per_segment_up_to_std():
    x = torch.zeros(256, 100, 8)
    y = motion_noise(x, 0.2, torch.Generator().manual_seed(1))
    per_segment = y.std(dim=(1, 2))
    assert per_segment.max() < 0.22 and per_segment.min() < 0.02 and 0.08 < per_segment.mean() < 0.12
    assert torch.equal(motion_noise(x, 0.0), x)


def test_augment_corrupts_inputs_but_never_targets(tmp_path):
    recipe = load_recipe("core-synthetic", ["training.steps=1"])
    trainer = Trainer(recipe, tmp_path, quiet=True)
    model = trainer.model
    motion, streams = trainer.sampler.batch(0, trainer.device)
    seen = {}
    encoder_forward, head_loss = model.encoder.forward, model.head.loss

    def enc(m, window):
        seen["motion"], seen["window"] = m, window
        return encoder_forward(m, window)

    def loss(latent, target, history, ctx):
        seen["target"] = target
        return head_loss(latent, target, history, ctx)

    model.encoder.forward, model.head.loss = enc, loss
    ctx = TrainContext(0, 0, generator=torch.Generator().manual_seed(0))
    augment = AugmentSpec(motion_noise=0.5, input_dropout={"motion": 0.5, "music": 0.5})
    model.training_loss(motion, streams, ctx, augment)
    w, t = model.window, model._lead() + model.window.motion_past
    torch.testing.assert_close(seen["target"], motion[:, t : t + model.head.frames])
    clean = motion[:, t - w.motion_past : t]
    assert (seen["motion"] - clean).abs().mean() > 0.05
    assert ((seen["motion"] == 0).all(-1)).float().mean() > 0.3
    clean = model.condition(streams)["music"][:, t - w.cond_past : t + w.cond_future]
    changed = (seen["window"]["music"] != clean).any(-1).float().mean()
    assert 0.4 < changed < 0.6  # music frames dropped (before the conditioner)


def test_unknown_dropout_input_is_a_recipe_error(tmp_path):
    recipe = load_recipe("core-synthetic", ["training.augment.input_dropout.lyrics=0.1"])
    with pytest.raises(RecipeError, match=r"training\.augment\.input_dropout\.lyrics"):
        Trainer(recipe, tmp_path, quiet=True)
    with pytest.raises(RecipeError, match="probability"):
        load_recipe("core-synthetic", ["training.augment.input_dropout.music=1.5"])


def test_generation_picks_one_thread_for_small_work_and_honours_an_explicit_count():
    from dance_core.runtime import SMALL_WORK, generation_threads

    before = torch.get_num_threads()
    try:
        small = torch.nn.Linear(100, 100)
        cpu = torch.device("cpu")
        assert generation_threads(small, 4, cpu, None) == 1 and torch.get_num_threads() == 1
        assert generation_threads(small, 4, cpu, 2) == 2 and torch.get_num_threads() == 2
        big = torch.nn.Linear(1000, SMALL_WORK // 1000 + 1)
        assert generation_threads(big, 1, cpu, None) == max(1, min(4, __import__("os").cpu_count() or 1))
    finally:
        torch.set_num_threads(before)
