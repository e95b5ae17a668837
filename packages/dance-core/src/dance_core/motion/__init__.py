"""Skeletal motion: skeletons, rotations, forward kinematics, root representations and resampling.

NumPy throughout (rotations through ``scipy.spatial.transform``). Quaternions are scalar-last ``(x, y, z, w)``
as in SciPy; positions are Y-up. This package module imports nothing heavy: ``Motion`` and
``Skeleton`` load on first use, so plugin entry modules may import ``dance_core.motion.configs``.
"""

from __future__ import annotations

from typing import Any

__all__ = ["Motion", "Skeleton"]


def __getattr__(name: str) -> Any:
    if name == "Motion":
        from dance_core.motion.motion import Motion

        return Motion
    if name == "Skeleton":
        from dance_core.motion.skeleton import Skeleton

        return Skeleton
    raise AttributeError(name)
