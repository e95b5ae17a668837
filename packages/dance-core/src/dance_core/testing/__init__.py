"""Helpers for testing dance plugins: contract checks any author can run, and temporary registration.

Each ``check_*`` function builds a component the way core does, through
``get_registry().create(kind, name, options, context)`` (so it works for installed plugins and for
plugin objects registered with :func:`registered_plugin`), then calls it the way the training and
composition loops call it: a head is driven by a real ``dance_core.model.ComposedModel``
(``training_loss`` and ``generate``, around a probe encoder), the other parts with small random
tensors or a short synthesized song. A broken contract is an ``AssertionError`` naming the component
and what is wrong; every check returns what it built, for further assertions. :func:`check_trains`
trains a recipe for a few steps. The pytest plugin ``dance_core.pytest_plugin`` wraps
:func:`registered_plugin` as fixtures. Importing this package imports no torch: the checks import it
when they run.

Modules: ``kit`` (registration, assertions), ``driven_model`` (the model around a head under test),
``model_parts`` (heads, encoders, conditioners), ``media_checks`` (features, metrics and their test
inputs), ``run_checks`` (datasets, schedules), ``component`` (any kind; a short training run).
"""

from dance_core.testing.component import check_component, check_trains
from dance_core.testing.kit import registered_plugin
from dance_core.testing.media_checks import check_feature, check_metric, dancing_clips, synthetic_audio
from dance_core.testing.model_parts import check_conditioner, check_encoder, check_head
from dance_core.testing.run_checks import check_dataset, check_schedule

__all__ = [
    "check_component",
    "check_conditioner",
    "check_dataset",
    "check_encoder",
    "check_feature",
    "check_head",
    "check_metric",
    "check_schedule",
    "check_trains",
    "dancing_clips",
    "registered_plugin",
    "synthetic_audio",
]
