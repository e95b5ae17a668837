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

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton
from dance_core.protocols import MotionData
from dance_core.registry import Registry

#: output units of lengths: metres per unit
UNITS = {"m": 1.0, "cm": 0.01}
#: built-in rigs by name
BUILT_IN = ("dance24", "transflower21")
#: up axes of the files written: Y (ours, glTF's) or Z (Blender's, 3ds Max's, Unreal's world)
UP_AXES = ("y", "z")
#: the formats that can be written Z up; glb is Y up by the glTF 2.0 specification (and FBX is made from it),
#: previews are drawn Y up
UP_FORMATS = ("bvh", "npz")


@dataclass(frozen=True)
class Delivery:
    """What to do to a finished dance: retarget onto ``rig`` (its maps, grounding the result unless
    ``ground`` is False), resample to ``fps``, convert to ``units``, write Z up (``up="z"``: the formats of
    ``UP_FORMATS``, by :func:`written_up`). ``None`` leaves each as it is."""

    rig: Skeleton | None = None
    rig_map: str | None = None
    source_map: str | None = None
    ground: bool = True
    fps: float | None = None
    units: str | None = None
    up: str | None = None

    @property
    def changes(self) -> bool:
        """True when the dance leaves in another skeleton, rate, units or up axis than the model's."""
        return self.rig is not None or self.fps is not None or self.units is not None or self.up == "z"


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
                  up: str | None = None, formats: list[str] | None = None, up_option: str = "--up") -> Delivery:
    """Check a delivery's inputs and resolve its rig: the maps' files, the rig file, and that the rig can
    be mapped (one line naming the option in ``options`` that gave it), and that one of ``formats`` (the
    names of the formats written) can take the up axis ``up`` (:func:`check_up`), before any work."""
    from dance_core.checks import check_input_file
    from dance_core.errors import DanceError

    for spec, option in ((rig_map, options[1]), (source_map, options[2])):
        if spec is not None and not is_preset(spec):
            check_input_file(spec, option, "joint map")
    if rig_map and not rig:
        raise DanceError(f"{options[1]}: only with {options[0]}")
    if units is not None and units not in UNITS:
        raise DanceError(f"units {units!r}: one of {', '.join(UNITS)}")
    check_up(up, formats or [], up_option)
    target = None
    if rig:
        from dance_core.motion.retarget import rig_frames

        target = rig_skeleton(rig, registry, options[0])
        rig_frames(target, rig_map, rig)  # a rig that cannot be mapped fails here, before any work
    return Delivery(target, rig_map, source_map, ground, fps, units, up)


def check_up(up: str | None, formats: list[str], option: str = "--up") -> None:
    """An up axis the files can be written with: Z up needs one format of ``UP_FORMATS`` among ``formats``
    (glb, and FBX made from it, are Y up by glTF's specification); else one line naming ``option``."""
    from dance_core.errors import DanceError

    if up is not None and up not in UP_AXES:
        raise DanceError(f"{option} {up!r}: one of {', '.join(UP_AXES)}")
    if up == "z" and formats and not set(formats) & set(UP_FORMATS):
        raise DanceError(f"{option} z: {', '.join(formats)} cannot be written Z up (glb is Y up by the glTF 2.0 "
                         f"specification, FBX is made from it, previews are drawn Y up); Z up is for "
                         f"{' and '.join(UP_FORMATS)} files")


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


def z_up(motion: Motion) -> Motion:
    """The motion in a Z-up world, its skeleton's ``up`` set to ``"z"``: a point (x, y, z) goes to
    (x, -z, y), so a dancer facing +Z (glTF's front) faces -Y, as in Blender. A motion already Z up is
    returned as it is; a BVH format writes it as it comes."""
    from dance_core.formats.bvh import Z_TO_Y_UP, reoriented
    from dance_core.motion.rotations import quat_conj

    if motion.skeleton.up == "z":
        return motion
    if motion.rotations is None and np.shape(motion.joint_positions)[-1] != 3:
        raise DataError(f"{motion.skeleton.name}: joint positions in {np.shape(motion.joint_positions)[-1]} "
                        "dimensions have no up axis to turn")
    return reoriented(motion, quat_conj(Z_TO_Y_UP), "z")


def written_up(data: MotionData, format_name: str, up: str | None) -> MotionData:
    """What the format ``format_name`` writes of a delivered dance (frame array: its joint positions) with the
    up axis ``up``: the dance turned Z up (:func:`z_up`) for a format of ``UP_FORMATS`` when ``up`` is z, else
    ``data`` itself (glb and previews are Y up whatever is asked)."""
    if up != "z" or format_name not in UP_FORMATS or data.skeleton_motion is None:
        return data
    return motion_data(z_up(data.skeleton_motion), data.meta)


def motion_data(motion: Motion, meta: dict | None = None) -> MotionData:
    """A skeletal motion as ``MotionData``: joint positions as the frame array (what feature formats write)."""
    from dance_core.formats.glb import positions_data

    return positions_data(motion, meta)


def dance_markers(motion: Motion, registry: Registry, music: str | Path | None = None, given=None,
                  tracker: str = "flux", start: float = 0.0):
    """The markers a delivered dance carries: the song's beats, downbeats and sections when ``music`` is
    given (:func:`dance_core.evaluation.song_markers.song_markers`; the dance starting ``start`` seconds
    into the song, times from its first frame), else ``given`` (markers read with the motion) or none;
    the foot contacts always found on ``motion`` itself."""
    from dance_core.motion.markers import Markers, contact_spans

    if music is not None:
        from dance_core.evaluation.song_markers import song_markers

        markers = song_markers(music, registry, motion, start=start, tracker=tracker)
    else:
        markers = given or Markers()
    markers.contacts = contact_spans(motion) or markers.contacts
    return markers
