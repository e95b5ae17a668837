"""What a checkpoint records about the motion its model makes: :class:`MotionInfo`.

A model works on frames of features (``dim`` channels at ``fps``). When they come from skeletal motion,
the checkpoint also records the motion representation that encoded them (its registered name and its
options, validated with defaults filled in, so decoding never depends on today's defaults) and the
skeleton they decode onto. The checkpoint stores :meth:`MotionInfo.to_dict` as JSON with sorted keys,
the same bytes the bare dict of earlier versions gave.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from dance_core.errors import DataError
from dance_core.motion.skeleton import Skeleton
from dance_core.protocols import MotionData

#: the keys :meth:`MotionInfo.to_dict` writes; any other key read from a checkpoint is kept as it was
KEYS = ("dim", "fps", "channels", "representation", "skeleton")


@dataclass(frozen=True)
class MotionInfo:
    """A model's motion: width, frame rate, channel names and, for skeletal motion, representation and skeleton."""

    dim: int
    fps: float
    channels: tuple[str, ...] | None = None
    #: the registered motion representation (``rotations``, ``positions``...), None for plain feature frames
    representation: str | None = None
    #: the representation's options, every one spelt out
    options: Mapping[str, Any] = field(default_factory=dict)
    skeleton: Skeleton | None = None
    #: keys of a stored description this version does not know, kept so that it is written back unchanged
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        if self.representation is not None and self.skeleton is None:
            raise DataError(f"motion description: representation {self.representation!r} without a skeleton")

    def to_dict(self) -> dict[str, Any]:
        """The JSON-able description a checkpoint stores."""
        info: dict[str, Any] = {"dim": self.dim, "fps": self.fps,
                                "channels": list(self.channels) if self.channels is not None else None}
        if self.representation is not None:
            info["representation"] = {"plugin": self.representation, **self.options}
            info["skeleton"] = self.skeleton.to_dict()
        return {**info, **self.extra}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MotionInfo:
        """Inverse of :meth:`to_dict`; a malformed description is a ``DataError``."""
        try:
            spec = data.get("representation") or None
            channels = data.get("channels")
            return cls(
                dim=int(data["dim"]),
                fps=data["fps"],
                channels=tuple(channels) if channels is not None else None,
                representation=spec["plugin"] if spec else None,
                options={k: v for k, v in spec.items() if k != "plugin"} if spec else {},
                skeleton=Skeleton.from_dict(data["skeleton"]) if spec else None,
                extra={k: v for k, v in data.items() if k not in KEYS},
            )
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise DataError(f"invalid motion description: {type(exc).__name__}: {exc}") from None

    def build_representation(self, registry: Any) -> Any:
        """The recorded motion representation, built with its recorded options."""
        return registry.create("motion-representation", self.representation, dict(self.options))

    def decode(self, values: Any, fps: float, registry: Any) -> MotionData:
        """Generated features as ``MotionData``, with the skeletal motion decoded when there is a
        representation (so skeleton formats such as BVH can write it)."""
        data = MotionData(values, fps, list(self.channels) if self.channels is not None else None)
        if self.representation is not None:
            data.skeleton_motion = self.build_representation(registry).decode(values, self.skeleton, fps)
        return data

    def encode(self, motion: MotionData, registry: Any) -> MotionData:
        """Motion read from a skeletal file (a seed) as this model's features at its fps; other motion as it is."""
        if motion.skeleton_motion is None or self.representation is None:
            return motion
        rep = self.build_representation(registry)
        where = motion.meta.get("path", "seed motion")
        skel_motion = motion.skeleton_motion.conformed(self.skeleton, where).resample(self.fps)
        return MotionData(rep.encode(skel_motion), self.fps, rep.channels(self.skeleton), motion.meta, skel_motion)
