"""Skeletal motion: skeletons, rotations, forward kinematics, root representations and resampling.

NumPy throughout (rotations through ``scipy.spatial.transform``); :mod:`dance_core.motion.torch_ops`
has the differentiable torch versions that models need. Quaternions are scalar-last ``(x, y, z, w)``
as in SciPy; positions are Y-up.
"""

from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton

__all__ = ["Motion", "Skeleton"]
