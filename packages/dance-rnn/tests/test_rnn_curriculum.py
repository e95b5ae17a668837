"""Dynamic auto-condition: the four registered schedules and the inputs the decoder is fed."""

import pytest
import torch

from dance_core.errors import RecipeError
from dance_core.model import build_model
from dance_core.protocols import TrainContext
from dance_core.recipe import load_recipe
from dance_core.registry import get_registry
from dance_rnn.curriculum import ground_truth_inputs


def schedule(name, **options):
    entry = get_registry().get("schedule", name)
    return entry.build(entry.config(**options))


@pytest.mark.parametrize(
    ("name", "options", "q_at_epoch"),
    [
        # core counts epochs from 0; t = epoch + 1 as in the paper and the reference code
        ("auto-condition-const", {"value": 7}, {0: 7, 50: 7, 10_000: 7}),
        ("auto-condition-linear", {}, {0: 0, 98: 0, 99: 1, 5499: 55, 9999: 100}),
        ("auto-condition-linear", {"rate": 0.29}, {99: 29, 9: 2}),  # 0.29 * 100 is 28.999999999999996
        ("auto-condition-linear", {"rate": 0.5, "limit": 3}, {1: 1, 5: 3, 100: 3}),
        ("auto-condition-quadratic", {}, {0: 0, 8: 0, 9: 1, 29: 9, 99: 100}),
        ("auto-condition-exponential", {}, {0: 0, 3: 0, 4: 1, 9: 220, 100: 1000, 10**6: 1000}),
        ("auto-condition-exponential", {"rate": 1.0, "offset": 0, "limit": 50}, {0: 1, 1: 2, 2: 7, 3: 20, 4: 50}),
    ],
)
def test_schedules_give_documented_q(name, options, q_at_epoch):
    fn = schedule(name, **options)
    assert {e: fn(0, e, 100) for e in q_at_epoch} == q_at_epoch


def test_exponential_schedule_requires_a_cap():
    with pytest.raises(RecipeError, match="limit"):
        load_recipe(
            "dancerevolution-small",
            ["training.schedules.auto_condition={plugin: auto-condition-exponential, limit: null}"],
        )


def test_ground_truth_pattern_alternates_p_true_then_q_generated():
    assert ground_truth_inputs(12, 3, 2) == [True] * 3 + [False] * 2 + [True] * 3 + [False] * 2 + [True] * 2
    assert ground_truth_inputs(5, 10, 0) == [True] * 5
    assert ground_truth_inputs(4, 1, 100) == [True, False, False, False]
    with pytest.raises(ValueError):
        ground_truth_inputs(4, 0, 1)


def small_model(*overrides, motion_dim=18):
    recipe = load_recipe("dancerevolution-small", list(overrides))
    return build_model(recipe, motion_dim, {"music": 4})


def test_training_inputs_hold_exactly_the_expected_ground_truth_and_generated_frames():
    head = small_model("model.head.teacher_frames=3").head
    gen = torch.Generator().manual_seed(0)
    latent, target, history = torch.randn(2, 17, 64), torch.randn(2, 17, 18), torch.randn(2, 1, 18)
    pred, inputs = head.rollout(latent, target, history, q=2, generator=gen)
    assert pred.shape == inputs.shape == (2, 17, 18)
    truth = torch.cat([history, target[:, :-1]], dim=1)
    expected = ground_truth_inputs(17, 3, 2)
    assert expected.count(False) == 6
    for i, is_truth in enumerate(expected):
        if is_truth:
            assert torch.equal(inputs[:, i], truth[:, i])
        else:  # the decoder's own prediction of the previous step, not the ground truth
            assert torch.equal(inputs[:, i], pred[:, i - 1].detach())
            assert not torch.allclose(inputs[:, i], truth[:, i])


def test_generated_inputs_are_detached():
    head = small_model("model.head.teacher_frames=3").head
    latent = torch.randn(1, 8, 64, requires_grad=True)
    pred, _ = head.rollout(latent, torch.randn(1, 8, 18), torch.randn(1, 1, 18), q=2)
    # output 3 is fed output 2 (generated input); latent 2 reaches output 3 only through that input
    grad = torch.autograd.grad(pred[:, 3].sum(), latent)[0]
    assert grad[0, 2].abs().max() == 0 and grad[0, 3].abs().max() > 0


def test_loss_reads_q_from_the_named_schedule():
    torch.manual_seed(0)
    head = small_model("model.head.teacher_frames=2").head
    latent, target, history = torch.randn(3, 12, 64), torch.randn(3, 12, 18), torch.randn(3, 1, 18)
    for q in (0, 3):
        ctx = TrainContext(
            step=0, epoch=0, values={"auto_condition": float(q)}, generator=torch.Generator().manual_seed(5)
        )
        pred, _ = head.rollout(latent, target, history, q, torch.Generator().manual_seed(5))
        assert torch.allclose(head.loss(latent, target, history, ctx)["loss"], (pred - target).abs().mean())
    with pytest.raises(RecipeError, match=r"^training\.schedules\.auto_condition: the lstm-decoder head"):
        head.loss(latent, target, history, TrainContext(step=0, epoch=0))
    forced = small_model("model.head.auto_condition=null").head
    assert forced.generated_per_period(TrainContext(step=0, epoch=0)) == 0


def test_trainer_hands_the_schedule_value_to_the_head(tmp_path):
    from dance_core.train import Trainer

    recipe = load_recipe(
        "dancerevolution-small",
        [
            "features.music=[{plugin: energy}]",
            "data.dataset.songs=3",
            "data.dataset.seconds=4",
            "data.segment_frames=20",
            "training.batch_size=4",
            "training.schedules.auto_condition={plugin: auto-condition-linear, rate: 1.0, offset: 0}",
        ],
    )
    trainer = Trainer(recipe, tmp_path, quiet=True)
    seen = []
    head = trainer.model.head
    original = head.rollout
    head.rollout = lambda *a, **k: seen.append(a[3]) or original(*a, **k)
    stage = trainer.stages[0]
    for step in (0, trainer.steps_per_epoch, 3 * trainer.steps_per_epoch):
        trainer._step(step, torch.optim.SGD(trainer.model.parameters(), lr=0.0), trainer._context(step, stage))
    assert seen == [0, 1, 3]
