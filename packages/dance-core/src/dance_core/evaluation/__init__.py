"""Evaluation of generated dances: motion features, the papers' metrics, reports and plots.

Every metric works on joint positions (``dance_core.protocols.JointClip``: ``(T, J, 3)`` metres,
Y up) at any frame rate, and is registered as a ``metric`` component by core's plugin. The entry
point of ``dance evaluate`` is :func:`dance_core.evaluation.report.evaluate`.

``__all__`` is the scoring library scripts may use (stable within a minor version, like ``dance_core``'s
names), loaded on first use: the quality measures, canonical poses, the move detectors, the realism
statistics and the loop measure (``sample_diversity`` is ``quality.diversity``: the submodule
``diversity`` has its name).
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> (defining module, its name there); imported on first use
_LAZY: dict[str, tuple[str, str]] = {
    **{n: ("dance_core.evaluation.quality", n) for n in ("quality_scores", "smoothness")},
    "sample_diversity": ("dance_core.evaluation.quality", "diversity"),
    **{n: ("dance_core.evaluation.canon", n) for n in ("canonicalize", "SMPL_HIPS")},
    "MoveValidity": ("dance_core.evaluation.move_validity", "MoveValidity"),
    **{n: ("dance_core.evaluation.move_detect", n) for n in ("DETECTORS", "detect", "move_share", "second_hits")},
    "joint_positions": ("dance_core.evaluation.loading", "joint_positions"),
    "z_up_to_y_up": ("dance_core.evaluation.clips", "z_up_to_y_up"),
    **{n: ("dance_core.evaluation.realism", n)
       for n in ("STATISTICS", "window_statistics", "realism_distance", "body_locking")},
    **{n: ("dance_core.evaluation.repetition", n) for n in ("self_repetition", "LOOP_BELOW")},
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'dance_core.evaluation' has no attribute {name!r}")
    module, attr = _LAZY[name]
    return getattr(importlib.import_module(module), attr)
