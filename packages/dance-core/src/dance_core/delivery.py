"""A finished dance delivered as an animator asks: onto their own rig, at their frame rate, in their units,
with the song's markers. ``dance compose`` (``--rig``, ``--fps``, ``--units``, ``--markers``; its
``compose.rig``, ``compose.output_fps``, ``compose.units``, ``compose.markers``), ``dance convert`` and
``dance retarget`` share it.

Everything a delivery reads (the rig file, the joint maps) is checked by :func:`plan_delivery`, before
any motion is generated or read; :func:`deliver` then only transforms.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton
from dance_core.protocols import MotionData
from dance_core.registry import Registry

#: output units of lengths: metres per unit
UNITS = {"m": 1.0, "cm": 0.01}
#: built-in rigs by name
BUILT_IN = ("dance24", "transflower21")


@dataclass(frozen=True)
class Delivery:
    """What to do to a finished dance: retarget onto ``rig`` (its maps, grounding the result unless
    ``ground`` is False), resample to ``fps``, convert to ``units``. ``None`` leaves each as it is."""

    rig: Skeleton | None = None
    rig_map: str | None = None
    source_map: str | None = None
    ground: bool = True
    fps: float | None = None
    units: str | None = None

    @property
    def changes(self) -> bool:
        """True when the dance leaves in another skeleton, rate or units than the model's."""
        return self.rig is not None or self.fps is not None or self.units is not None


def is_preset(spec: str) -> bool:
    """True when ``spec`` names a built-in joint map (else it is a YAML file)."""
    from dance_core.motion.rig_maps import PRESETS

    return spec in PRESETS


def rig_skeleton(spec: str, registry: Registry, option: str = "--rig") -> Skeleton:
    """The skeleton to retarget onto: a built-in by name, or the skeleton of a motion file (a missing
    file, or one without a skeleton, is one line naming ``option``)."""
    from dance_core.checks import check_input_file
    from dance_core.data.files import read_motion_file
    from dance_core.motion import skeletons

    if spec in BUILT_IN:
        return getattr(skeletons, spec)()
    check_input_file(spec, option, "rig file")
    data = read_motion_file(spec, registry)
    if data.skeleton_motion is None:
        raise DataError(f"{option} {spec}: has no skeleton (a plain feature file); give a BVH or another skeletal file")
    return data.skeleton_motion.skeleton


def plan_delivery(registry: Registry, rig: str | None = None, rig_map: str | None = None,
                  source_map: str | None = None, ground: bool = True, fps: float | None = None,
                  units: str | None = None, options: tuple[str, str, str] = ("--rig", "--rig-map", "--source-map"),
                  ) -> Delivery:
    """Check a delivery's inputs and resolve its rig: the maps' files, the rig file, and that the rig can
    be mapped (one line naming the option in ``options`` that gave it), before any work."""
    from dance_core.checks import check_input_file
    from dance_core.errors import DanceError

    for spec, option in ((rig_map, options[1]), (source_map, options[2])):
        if spec is not None and not is_preset(spec):
            check_input_file(spec, option, "joint map")
    if rig_map and not rig:
        raise DanceError(f"{options[1]}: only with {options[0]}")
    if units is not None and units not in UNITS:
        raise DanceError(f"units {units!r}: one of {', '.join(UNITS)}")
    target = None
    if rig:
        from dance_core.motion.retarget import rig_frames

        target = rig_skeleton(rig, registry, options[0])
        rig_frames(target, rig_map, rig)  # a rig that cannot be mapped fails here, before any work
    return Delivery(target, rig_map, source_map, ground, fps, units)


def in_units(motion: Motion, units: str) -> Motion:
    """The motion with its lengths in ``units`` (m or cm), from its skeleton's units or their guess."""
    from dance_core.formats.glb import metres_per_unit

    factor = metres_per_unit(motion.skeleton) / UNITS[units]
    return replace(motion, skeleton=motion.skeleton.scaled(factor, units), root=motion.root * factor)


def deliver(motion: Motion, delivery: Delivery, where: str = "motion") -> tuple[Motion, str]:
    """The motion retargeted, resampled and in the units asked for, and the retarget engine's note
    (empty without a rig)."""
    note = ""
    if delivery.rig is not None:
        from dance_core.motion.retarget import retarget

        motion, report = retarget(motion, delivery.rig, delivery.source_map, delivery.rig_map,
                                  ground=delivery.ground, where=where)
        note = report.summary()
    if delivery.fps:
        motion = motion.resample(delivery.fps)
    if delivery.units:
        motion = in_units(motion, delivery.units)
    return motion, note


def motion_data(motion: Motion, meta: dict | None = None) -> MotionData:
    """A skeletal motion as ``MotionData``: joint positions as the frame array (what feature formats write)."""
    positions = motion.positions()
    channels = [f"{name}.{axis}" for name in motion.skeleton.names for axis in "xyz"]
    return MotionData(positions.reshape(len(positions), -1).astype("float32"), motion.fps, channels,
                      dict(meta or {}), motion)


def dance_markers(motion: Motion, registry: Registry, music: str | Path | None = None, given=None,
                  tracker: str = "flux"):
    """The markers a delivered dance carries: the song's beats, downbeats and sections when ``music`` is
    given (:func:`dance_core.evaluation.song_markers.song_markers`), else ``given`` (markers read with the
    motion) or none; the foot contacts always found on ``motion`` itself."""
    from dance_core.motion.markers import Markers, contact_spans

    if music is not None:
        from dance_core.evaluation.song_markers import song_markers

        markers = song_markers(music, registry, motion, tracker=tracker)
    else:
        markers = given or Markers()
    markers.contacts = contact_spans(motion) or markers.contacts
    return markers
