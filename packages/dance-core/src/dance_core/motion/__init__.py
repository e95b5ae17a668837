"""Skeletal motion: skeletons, rotations, forward kinematics, root representations and resampling,
retargeting and grounding.

NumPy throughout (rotations through ``scipy.spatial.transform``). Quaternions are scalar-last ``(x, y, z, w)``
as in SciPy; positions are Y-up. This package module imports nothing heavy: its names load on first use,
so plugin entry modules may import ``dance_core.motion.configs``. ``__all__`` is the motion library
scripts may use (stable within a minor version, like ``dance_core``'s names): ``Motion`` and
``Skeleton``, the ``dance24`` skeleton, forward kinematics, rotations, rig frames, grounding and beat alignment
(``retarget`` itself is ``dance_core.api.retarget``: the submodule ``motion.retarget`` shares its name).
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> the module that defines it (imported on first use)
_LAZY: dict[str, str] = {
    "Motion": "dance_core.motion.motion",
    "Skeleton": "dance_core.motion.skeleton",
    "dance24": "dance_core.motion.skeletons",
    **dict.fromkeys(("forward_kinematics", "end_site_positions", "joint_positions"), "dance_core.motion.fk"),
    **dict.fromkeys(("expmap_to_quat", "quat_rotate", "quat_slerp"), "dance_core.motion.rotations"),
    **dict.fromkeys(("rig_frames", "RigFrames"), "dance_core.motion.retarget"),  # retarget: dance_core.api
    **dict.fromkeys(("renamed", "arms_lowered"), "dance_core.motion.rig_maps"),
    **dict.fromkeys(("ground", "GroundingOptions", "find_feet", "foot_contacts", "foot_speeds", "sole_heights",
                     "soles"), "dance_core.motion.grounding"),
    **dict.fromkeys(("align_to_beats", "Alignment"), "dance_core.motion.beat_align"),
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'dance_core.motion' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
