import json
import math

import numpy as np
import pytest
import torch

from dance_core import hookimpl
from dance_core.checkpoint import check_matches, load_checkpoint, load_weights
from dance_core.components.configs import RegressionHeadConfig
from dance_core.components.modules import RegressionHead
from dance_core.errors import CheckpointError, TrainingError
from dance_core.model import build_model
from dance_core.recipe import load_recipe
from dance_core.testing import registered_plugin
from dance_core.train import Trainer, train


def weights(path):
    return load_checkpoint(path).weights


def test_core_recipe_learns_beats_below_mean_pose_baseline(tmp_path):
    recipe = load_recipe("core-synthetic", ["training.steps=400"])
    trainer = Trainer(recipe, tmp_path, quiet=True)
    result = trainer.run()
    # the mean pose is 0 in standardized units: its L1 loss is the mean |target|
    baseline = np.mean([trainer.val_sampler.batch(i)[0].abs().mean().item() for i in range(4)])
    assert result.last_loss < 0.15 * result.first_loss
    assert result.val_loss < 0.25 * baseline
    log = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
    assert log[-1]["val_loss"] == pytest.approx(result.val_loss)
    assert {"step", "lr", "loss", "epoch", "segments_per_s"} <= set(log[0])


def test_checkpoint_round_trip_and_metadata(tiny_recipe, tmp_path):
    recipe = tiny_recipe()
    result = train(recipe, out=str(tmp_path), quiet=True)
    ckpt = load_checkpoint(result.checkpoint)
    assert ckpt.step == 40 and ckpt.motion.dim == 18 and ckpt.motion.fps == 20
    assert ckpt.recipe["model"] == recipe.model_dump(mode="json")["model"]
    assert "torch" in ckpt.versions and "dance-core" in ckpt.versions
    model = build_model(recipe, 18, {"music": 4})
    load_weights(model, ckpt)
    for name, value in model.state_dict().items():
        assert torch.equal(value, ckpt.weights[name])
    check_matches(ckpt, recipe)
    assert ckpt.stats.motion.mean.shape == (18,)
    assert (tmp_path / "recipe.yaml").exists()


def test_checkpoint_refuses_a_recipe_it_does_not_match(tiny_recipe, tmp_path):
    result = train(tiny_recipe(), out=str(tmp_path), quiet=True)
    check_matches(load_checkpoint(result.checkpoint), tiny_recipe("model.head.hidden=256"))  # the default, spelt out
    other = tiny_recipe("model.encoder.dim=64")
    with pytest.raises(CheckpointError, match=r"model\.encoder\.dim differ"):
        check_matches(load_checkpoint(result.checkpoint), other)
    model = build_model(other, 18, {"music": 4})
    with pytest.raises(CheckpointError, match="weights do not fit"):
        load_weights(model, load_checkpoint(result.checkpoint))


def test_corrupt_or_foreign_checkpoint_is_one_line(tmp_path):
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(b"\x00" * 64)
    with pytest.raises(CheckpointError, match="not a readable safetensors") as err:
        load_checkpoint(bad)
    assert "\n" not in str(err.value)
    from safetensors.torch import save_file

    save_file({"x": torch.zeros(2)}, str(tmp_path / "foreign.safetensors"))
    with pytest.raises(CheckpointError, match="not a dance checkpoint"):
        load_checkpoint(tmp_path / "foreign.safetensors")
    with pytest.raises(CheckpointError, match="not found"):
        load_checkpoint(tmp_path / "missing.safetensors")


def test_resume_equals_an_uninterrupted_run(tiny_recipe, tmp_path):
    recipe = tiny_recipe("training.checkpoint_every=1000", "model.conditioners.music.dropout=0.2")
    straight = train(recipe, out=str(tmp_path / "a"), quiet=True)
    first = train(recipe, out=str(tmp_path / "b"), quiet=True, stop_at=17)
    assert load_checkpoint(first.checkpoint).step == 17
    resumed = train(recipe, out=str(tmp_path / "b"), quiet=True, resume=True)
    assert resumed.steps == 40
    a, b = weights(straight.checkpoint), weights(resumed.checkpoint)
    assert all(torch.equal(a[k], b[k]) for k in a)
    log_a = (tmp_path / "a" / "log.jsonl").read_text().splitlines()
    log_b = (tmp_path / "b" / "log.jsonl").read_text().splitlines()

    def strip(lines):
        return [{k: v for k, v in json.loads(x).items() if k != "segments_per_s"} for x in lines]

    assert [r for r in strip(log_b) if r["step"] != 17] == strip(log_a)


def test_a_kill_between_the_pairs_renames_resumes_from_the_previous_pair(tiny_recipe, tmp_path):
    """SIGKILL cannot be held off: landing between the renames of a checkpoint pair it leaves the new
    model beside the old training state. The old model, kept until both are in place, is taken back
    and the resumed run equals an uninterrupted one."""
    import os
    import shutil

    recipe = tiny_recipe("training.checkpoint_every=1000")
    straight = train(recipe, out=str(tmp_path / "a"), quiet=True)
    run = tmp_path / "b"
    train(recipe, out=str(run), quiet=True, stop_at=17)
    later = train(recipe, out=str(tmp_path / "c"), quiet=True, stop_at=23)  # the model the kill published
    os.link(run / "model.safetensors", run / "model.previous.safetensors")  # what save() keeps meanwhile
    shutil.copyfile(later.checkpoint, tmp_path / "published")
    os.replace(tmp_path / "published", run / "model.safetensors")  # the first of the pair's two renames
    assert load_checkpoint(run / "model.safetensors").step == 23
    resumed = train(recipe, out=str(run), quiet=True, resume=True)
    a, b = weights(straight.checkpoint), weights(resumed.checkpoint)
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not (run / "model.previous.safetensors").exists()


def test_resume_without_a_run_is_a_clear_error(tiny_recipe, tmp_path):
    with pytest.raises(CheckpointError, match="not found"):
        train(tiny_recipe(), out=str(tmp_path), quiet=True, resume=True)


def test_same_seed_same_weights_different_seed_differs(tiny_recipe, tmp_path):
    a = weights(train(tiny_recipe(), out=str(tmp_path / "a"), quiet=True).checkpoint)
    b = weights(train(tiny_recipe(), out=str(tmp_path / "b"), quiet=True).checkpoint)
    c = weights(train(tiny_recipe("data.dataset.songs=6"), out=str(tmp_path / "c"), quiet=True).checkpoint)
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)


class NanHead(RegressionHead):
    def loss(self, latent, target, history, ctx):
        out = super().loss(latent, target, history, ctx)
        if ctx.step >= 25:
            out["loss"] = out["loss"] * math.nan
        return out


class NanPlugin:
    @hookimpl
    def register_heads(self, register):
        register(
            "nan-head",
            RegressionHeadConfig,
            lambda c, *, motion_dim, latent_dim, **_: NanHead(c, motion_dim, latent_dim, None),
        )


def test_nan_loss_stops_with_message_and_keeps_last_good_checkpoint(tiny_recipe, tmp_path):
    with registered_plugin(NanPlugin(), "nan-plugin"):
        recipe = tiny_recipe("model.head.plugin=nan-head")
        with pytest.raises(TrainingError) as err:
            train(recipe, out=str(tmp_path), quiet=True)
    msg = str(err.value)
    assert "step 25" in msg and "loss is nan" in msg and str(tmp_path / "model.safetensors") in msg
    ckpt = load_checkpoint(tmp_path / "model.safetensors")
    assert ckpt.step == 20 and all(torch.isfinite(v).all() for v in ckpt.weights.values())


def test_stages_train_only_their_prefixes(tiny_recipe, tmp_path):
    recipe = tiny_recipe("training.stages=[{name: heads, steps: 10, trainable: [head.]}, {name: all, steps: 5}]")
    trainer = Trainer(recipe, tmp_path, quiet=True)
    before = {k: v.clone() for k, v in trainer.model.state_dict().items()}
    trainer.run(stop_at=10)
    after = trainer.model.state_dict()
    changed = {k for k in before if not torch.equal(before[k], after[k])}
    assert changed and all(k.startswith("head.") for k in changed)
    trainer.run(resume=True)
    assert any(not torch.equal(before[k], trainer.model.state_dict()[k]) for k in before if k.startswith("encoder."))


def test_a_stage_may_set_its_own_batch_size(tiny_recipe, tmp_path):
    recipe = tiny_recipe(
        "training.stages=[{name: big, steps: 3, batch_size: 24}, {name: small, steps: 2, batch_size: 5}]"
    )
    trainer = Trainer(recipe, tmp_path, quiet=True)
    sizes = []
    real = trainer.sampler.draw
    trainer.sampler.draw = lambda step, device, size=None: sizes.append(size) or real(step, device, size)
    trainer.run()
    assert sizes == [24, 24, 24, 5, 5]
    assert real(0, "cpu", 7).motion.shape[0] == 7 and real(0, "cpu").motion.shape[0] == recipe.training.batch_size


def test_init_takes_a_checkpoints_weights_and_statistics(tiny_recipe, tmp_path):
    first = train(tiny_recipe(), out=str(tmp_path / "a"), quiet=True).checkpoint
    old = load_checkpoint(first)
    # a new encoder of another width over the old head is not possible; a new head over the old encoder is
    recipe = tiny_recipe(f"training.init={{checkpoint: {first}, weights: [encoder.]}}", "data.dataset.songs=6",
                         "training.stages=[{name: head, steps: 4, trainable: [head.]}]")
    trainer = Trainer(recipe, tmp_path / "b", quiet=True)
    own = trainer.model.state_dict()
    assert all(torch.equal(own[k], old.weights[k]) for k in own if k.startswith("encoder."))
    assert not all(torch.equal(own[k], old.weights[k]) for k in own if k.startswith("head."))
    fitted = Trainer(tiny_recipe("data.dataset.songs=6"), tmp_path / "c", quiet=True).stats.to_arrays()
    ours, theirs = trainer.stats.to_arrays(), old.stats.to_arrays()
    assert all(np.array_equal(ours[k], theirs[k]) for k in ours)  # the checkpoint's, not the new split's
    assert not all(np.array_equal(fitted[k], theirs[k]) for k in fitted)
    trainer.run()
    after = load_checkpoint(tmp_path / "b" / "model.safetensors")
    assert all(torch.equal(after.weights[k], old.weights[k]) for k in after.weights if k.startswith("encoder."))
    refit = Trainer(tiny_recipe(f"training.init={{checkpoint: {first}, stats: false}}", "data.dataset.songs=6"),
                    tmp_path / "d", quiet=True)
    assert all(np.array_equal(refit.stats.to_arrays()[k], fitted[k]) for k in fitted)
    assert all(torch.equal(v, old.weights[k]) for k, v in refit.model.state_dict().items())  # '' takes all


def test_init_errors_name_the_checkpoint_and_the_field(tiny_recipe, tmp_path):
    first = train(tiny_recipe(), out=str(tmp_path / "a"), quiet=True).checkpoint
    with pytest.raises(CheckpointError, match="not found|no such|does not exist"):
        missing = tmp_path / "none.safetensors"
        Trainer(tiny_recipe(f"training.init={{checkpoint: {missing}}}"), tmp_path / "b", quiet=True)
    with pytest.raises(CheckpointError, match=r"training.init.weights: the checkpoint has no parameter starting with "
                                              r"'heads.'"):
        Trainer(tiny_recipe(f"training.init={{checkpoint: {first}, weights: [heads.]}}"), tmp_path / "c", quiet=True)
    with pytest.raises(CheckpointError, match=r"training.init.weights: encoder\..* has shape"):
        Trainer(tiny_recipe(f"training.init={{checkpoint: {first}, weights: [encoder.]}}", "model.encoder.dim=64"),
                tmp_path / "d", quiet=True)


def test_training_output_fills_in_the_name_but_formats_nothing_else(tiny_recipe, tmp_path):
    """``training.output`` is user input: ``{name}`` is replaced, any other brace stays as written (no
    ``str.format`` of a recipe field: ``{name.__class__}`` or ``{0}`` reach nothing)."""
    from dance_core.train.run_folder import run_dir_for

    recipe = tiny_recipe(f"training.output={tmp_path}/{{name}}-{{name.__class__.__mro__}}-{{0}}")
    assert run_dir_for(recipe) == tmp_path / f"{recipe.name}-{{name.__class__.__mro__}}-{{0}}"
