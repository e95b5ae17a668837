"""The VQ-VAE's loss on joint positions: L1 between the joints of the reconstruction and of the motion.

Both motions go through the training data's forward kinematics (``TrainContext.kinematics``, core's
:class:`dance_core.motion.torch_fk.RotationKinematics`: positions in metres, in the body's own frame),
so the loss sees what the rotation channels spread out: a foot's height, a hand's reach. Joints weigh
``position_weights`` (by name, others 1), averaged over the joints by those weights.
"""

from __future__ import annotations

from typing import Any

import torch

from dance_core import RecipeError


def joint_weights(names: list[str], weights: dict[str, float]) -> torch.Tensor:
    """Per joint its weight ``(J,)``, normalized to sum 1; an unknown joint name is a recipe error."""
    unknown = sorted(set(weights) - set(names))
    if unknown:
        raise RecipeError(f"model.head.tokenizer.position_weights: no joint {unknown[0]!r} in the skeleton "
                          f"(joints: {', '.join(names)})")
    w = torch.tensor([float(weights.get(n, 1.0)) for n in names])
    if w.sum() <= 0:
        raise RecipeError("model.head.tokenizer.position_weights: every joint weighs 0")
    return w / w.sum()


def position_losses(recon: torch.Tensor, motion: torch.Tensor, kinematics: Any,
                    weights: dict[str, float]) -> tuple[torch.Tensor, torch.Tensor]:
    """L1 errors of the joint positions ``(metres)`` and of their frame-to-frame differences between
    ``recon`` and ``motion`` (standardized, ``(B, T, D)``), each a weighted mean over joints."""
    if kinematics is None:
        raise RecipeError("model.head.tokenizer.positions / position_velocity need joint positions: the motion "
                          "must be the `rotations` representation with expmap, axis-angle or quat rotations")
    w = joint_weights(kinematics.names, weights).to(recon.device, recon.dtype)
    got, want = kinematics(recon), kinematics(motion)
    per_joint = (got - want).abs().mean(dim=-1)  # (B, T, J)
    position = (per_joint * w).sum(-1).mean()
    step = (torch.diff(got, dim=-3) - torch.diff(want, dim=-3)).abs().mean(dim=-1)
    velocity = (step * w).sum(-1).mean()
    return position, velocity
