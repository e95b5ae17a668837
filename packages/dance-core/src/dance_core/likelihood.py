"""Held-out NLL: a trained model's negative log-likelihood of dances it never saw.

Not a registered metric: a metric scores joint positions (``protocols.Metric``) and never reaches a
model, while a likelihood needs the model, its checkpoint's normalization and the dances in its
motion representation. A head has a likelihood when its ``loss`` reports ``nats_per_frame`` (the
NLL of one frame of the standardized motion representation, in nats, as dance-flow's ``flow`` head
does); for any other head (regression, LSTM, TM2D's token cross-entropy) the answer is ``None``
(n/a). Values compare models that share the representation and the training data (hence the
standardization); they are not comparable across datasets.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from dance_core.errors import DataError

#: the loss entry a head with a likelihood reports (NLL per frame, nats, standardized motion)
NLL_KEY = "nats_per_frame"


def held_out_nll(
    recipe,
    checkpoint: str | Path,
    sources: Sequence,
    *,
    batches: int = 8,
    batch_size: int = 32,
    seed: int = 0,
) -> float | None:
    """Mean NLL per frame (nats) of ``batches`` fixed batches of segments cut from ``sources``
    (``ClipSource``s as a dataset yields them: encoded with the recipe's motion representation,
    mirrored copies included when the recipe mirrors), standardized with the checkpoint's statistics;
    ``None`` when the model's head reports no likelihood."""
    import torch

    from dance_core.compose import load_model
    from dance_core.data.prepare import prepare_data
    from dance_core.data.sampling import SegmentSampler
    from dance_core.protocols import TrainContext
    from dance_core.registry import get_registry

    if not sources:
        raise DataError("held-out NLL: no clips to score")
    registry = get_registry()
    model, ckpt, stack = load_model(recipe, checkpoint, torch.device("cpu"))
    clips = prepare_data(recipe, stack, registry, sources).standardized(ckpt.stats)  # as training prepares its data
    length = model.segment_frames(recipe.data.segment_frames if recipe.data else None)
    sampler = SegmentSampler(clips, length, batch_size, seed, "held-out")
    # every schedule at 0 (a curriculum head then teacher-forces); the value is not used by a flow
    schedules = {name: 0.0 for name in recipe.training.schedules} if recipe.training else {}
    values = []
    with torch.no_grad():
        for i in range(batches):
            batch = sampler.draw(i)
            generator = torch.Generator().manual_seed(i)
            ctx = TrainContext(step=0, epoch=0, stage="eval", values=dict(schedules), generator=generator)
            out = model.training_loss(batch.motion, batch.streams, ctx, spans=batch.spans)
            if NLL_KEY not in out:
                return None
            values.append(float(out[NLL_KEY]))
    return float(np.mean(values))
