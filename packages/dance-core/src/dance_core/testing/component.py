"""One check for any component kind, and a short training run of a whole recipe."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dance_core.errors import DanceError
from dance_core.testing.kit import Check, create
from dance_core.testing.media_checks import check_feature, check_metric
from dance_core.testing.model_parts import check_conditioner, check_encoder, check_head
from dance_core.testing.run_checks import check_dataset, check_schedule


def check_component(
    kind: str,
    name: str,
    options: Mapping[str, Any] | None = None,
    context: Any = None,
    **kwargs: Any,
) -> Any:
    """Check component ``name`` of ``kind`` with the check of its kind, the context's fields (a
    ``HeadContext``, ``EncoderContext``, ``ConditionerContext`` or ``DatasetContext``) as its arguments;
    kinds without a check of their own are built and checked against their protocol. ``kwargs`` go to
    the kind's check. Returns what the check returns."""
    fields = {} if context is None else {k: getattr(context, k) for k in context.__dataclass_fields__}
    if kind == "head":
        return check_head(name, options, **fields, **kwargs)
    if kind == "encoder":
        return check_encoder(name, options, **fields, **kwargs)
    if kind == "conditioner":
        return check_conditioner(name, options, **fields, **kwargs)
    if kind == "dataset":
        return check_dataset(name, options, **fields, **kwargs)
    simple = {"feature": check_feature, "metric": check_metric, "schedule": check_schedule}
    if kind in simple:
        return simple[kind](name, options, **kwargs)
    return create(kind, name, options, context, kwargs.get("registry"))[0]


def check_trains(
    recipe: str | Path,
    out_dir: str | Path,
    *,
    steps: int = 20,
    overrides: Sequence[str] = (),
    weights: str | None = None,
) -> Any:
    """Train ``recipe`` (a file or a registered recipe name) for ``steps`` steps into ``out_dir`` through
    ``dance_core.train`` and check the run: finite losses and a checkpoint, which holds weights named
    ``weights*`` when given (``"head."``, ``"encoder."``, ``"conditioners.music."``). ``overrides`` are
    ``--set`` assignments (``"data.dataset.songs=4"``). Returns the ``TrainResult``."""
    from dance_core.checkpoint import load_checkpoint
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    check = Check(f"recipe {str(recipe)!r}")
    sets = [f"training.steps={steps}", f"training.val_every={steps}", f"training.checkpoint_every={steps}"]
    try:
        result = train(load_recipe(recipe, [*sets, *overrides]), out=str(out_dir), quiet=True)
    except DanceError as exc:
        raise AssertionError(f"{check.label}: {exc}") from exc
    check.that(result.steps == steps, f"trained {result.steps} steps, expected {steps}")
    for what, value in (("first", result.first_loss), ("last", result.last_loss), ("validation", result.val_loss)):
        check.that(value is None or math.isfinite(value), f"the {what} loss is {value}")
    check.that(Path(result.checkpoint).is_file(), f"no checkpoint at {result.checkpoint}")
    if weights is not None:
        names = [k for k in load_checkpoint(result.checkpoint).weights if k.startswith(weights)]
        check.that(names, f"the checkpoint holds no weights named {weights}* (is the component an nn.Module?)")
    return result
