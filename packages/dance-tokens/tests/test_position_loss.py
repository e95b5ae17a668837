"""The VQ-VAE's loss on joint positions (forward kinematics of the standardized `rotations` motion)."""

import numpy as np
import pytest
import torch
from pydantic import ValidationError

from dance_core import RecipeError
from dance_core.motion.representation import RotationRepresentation
from dance_core.motion.torch_fk import RotationKinematics
from dance_core.synth.synthetic_dance import make_clip
from dance_tokens.configs import TokenizerConfig
from dance_tokens.positions import position_losses
from dance_tokens.vqvae import MotionVQVAE

FEET = {"L_Ankle": 4.0, "R_Ankle": 4.0, "L_Foot": 4.0, "R_Foot": 4.0}


@pytest.fixture(scope="module")
def dance():
    """Standardized expmap + deltas features (1, 64, D) of a synthetic dance, and their kinematics."""
    motion = make_clip(0, seed=1, seconds=2.2, bpm=(90, 130), rate=8000, fps=30.0).motion.skeleton_motion
    rep = RotationRepresentation("expmap", "deltas")
    values = rep.encode(motion)[:64]
    mean, std = values.mean(0), values.std(0) + 0.05
    kin = RotationKinematics(motion.skeleton, {"rotation": "expmap", "root": "deltas"}, mean, std)
    features = torch.tensor((values - mean) / std)[None]
    return features, kin, rep.channels(motion.skeleton), std


def test_a_perfect_reconstruction_costs_nothing(dance):
    features, kin, _, _ = dance
    position, velocity = position_losses(features.clone(), features, kin, FEET)
    assert float(position) == 0.0 and float(velocity) == 0.0


def test_a_raised_body_costs_its_height_in_every_joint(dance):
    features, kin, channels, std = dance
    raised = features.clone()
    raised[..., channels.index("root.y")] += 0.05 / float(std[channels.index("root.y")])  # 5 cm up
    position, velocity = position_losses(raised, features, kin, FEET)
    assert float(position) == pytest.approx(0.05 / 3, abs=1e-5)  # y off by 5 cm, x and z exact
    assert float(velocity) == pytest.approx(0.0, abs=1e-5)  # the same offset in every frame


def test_the_loss_grows_with_a_foots_height_error_and_its_weight(dance):
    features, kin, channels, std = dance
    knee = channels.index("L_Knee.expmap.x")

    def bent(radians):
        out = features.clone()
        out[..., knee] += radians / float(std[knee])
        return out

    small, _ = position_losses(bent(0.1), features, kin, {})
    large, _ = position_losses(bent(0.4), features, kin, {})
    weighted, _ = position_losses(bent(0.4), features, kin, FEET)
    assert 0 < float(small) < float(large) < float(weighted)  # only the shin and foot move: feet weigh more


def test_vqvae_adds_the_weighted_position_terms(dance):
    features, kin, _, _ = dance
    config = dict(codes=32, code_dim=8, width=16)
    torch.manual_seed(0)
    plain = MotionVQVAE(features.shape[-1], TokenizerConfig(**config))
    torch.manual_seed(0)
    model = MotionVQVAE(features.shape[-1], TokenizerConfig(**config, positions=2.0, position_velocity=3.0,
                                                            position_weights=FEET))
    base = plain.loss(features, torch.Generator().manual_seed(0))
    out = model.loss(features, torch.Generator().manual_seed(0), kin)
    recon, _ = plain(features)
    position, velocity = position_losses(recon, features, kin, FEET)
    assert float(out["positions"]) > 0 and torch.isclose(out["positions"], position)
    assert torch.isclose(out["loss"], base["loss"] + 2.0 * position + 3.0 * velocity)
    with pytest.raises(RecipeError, match="rotations"):
        model.loss(features, None, None)


def test_unknown_joints_and_negative_weights_fail(dance):
    features, kin, _, _ = dance
    with pytest.raises(RecipeError, match="L_Toe"):
        position_losses(features, features, kin, {"L_Toe": 2.0})
    with pytest.raises(ValidationError, match="negative"):
        TokenizerConfig(positions=1.0, position_weights={"L_Foot": -1.0})
    assert np.isfinite(float(position_losses(features, features, kin, {})[0]))


def test_trainer_hands_the_tokenizer_the_kinematics_of_its_motion(tmp_path):
    """Through core's Trainer: the tokenizer stage of a shrunk tm2d-small logs the position terms."""
    import json

    import dance_tokens.plugin as plugin
    from dance_core.recipe import load_recipe
    from dance_core.testing import registered_plugin
    from dance_core.train import Trainer

    from .test_recipes import SHRUNK, stages

    options = ["model.head.tokenizer={codes: 16, code_dim: 8, width: 16, crop: 64, positions: 1.0,"
               " position_velocity: 1.0, position_weights: {L_Foot: 4.0}}", "training.log_every=1"]
    with registered_plugin(plugin, "tokens"):
        recipe = load_recipe("tm2d-small", [*SHRUNK, *options, stages(2, 1)])
        trainer = Trainer(recipe, tmp_path / "run", quiet=True)
        assert trainer.kinematics is not None and "L_Foot" in trainer.kinematics.names
        trainer.run(stop_at=2)
    rows = [json.loads(line) for line in (tmp_path / "run" / "log.jsonl").read_text().splitlines()]
    logged = [r["positions"] for r in rows if "positions" in r]
    assert len(logged) == 2 and all(0 < v < 1 for v in logged)  # metres of error, untrained
