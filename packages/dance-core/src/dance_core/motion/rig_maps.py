"""Joint-name maps between rigs: every rig is mapped onto one canonical body, SMPL-24's joint names.

A map says, for each canonical joint, which joint of a rig plays its part (a list: the first name the
rig has wins, e.g. Unreal's chest is ``spine_05`` in UE5 and ``spine_03`` in UE4). Built in: ``smpl``
(our ``dance24`` and AIST++), ``cmu`` (the CMU database as cgspeed converted it), ``cmu-daz`` (the
"Daz-friendly" CMU conversion), ``mixamo`` (``mixamorig:`` prefixes or none; also Transflower's set)
and ``unreal`` (the UE4/UE5 mannequin). A user map is a YAML mapping ``canonical name: rig joint``.
Names match exactly after a namespace prefix (``mixamorig:``, ``Armature|``) is removed, then ignoring case.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from dance_core.errors import DataError
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import SMPL_NAMES

#: canonical joints a retargeting source or target must have (the rest are optional)
REQUIRED = (
    "Pelvis", "L_Hip", "R_Hip", "L_Knee", "R_Knee", "L_Ankle", "R_Ankle",
    "L_Shoulder", "R_Shoulder", "L_Elbow", "R_Elbow", "L_Wrist", "R_Wrist", "Head",
)


def _sided(table: dict[str, tuple[str, ...]], left: str, right: str) -> dict[str, tuple[str, ...]]:
    """Expand ``X_`` keys into ``L_``/``R_`` and ``{s}`` in names into the rig's side words."""
    out: dict[str, tuple[str, ...]] = {}
    for key, names in table.items():
        if key.startswith("X_"):
            out["L_" + key[2:]] = tuple(n.replace("{s}", left) for n in names)
            out["R_" + key[2:]] = tuple(n.replace("{s}", right) for n in names)
        else:
            out[key] = names
    return out


PRESETS: dict[str, dict[str, tuple[str, ...]]] = {
    "smpl": {n: (n,) for n in SMPL_NAMES},
    "cmu": _sided({
        "Pelvis": ("Hips",), "Spine1": ("LowerBack",), "Spine2": ("Spine",), "Spine3": ("Spine1",),
        "Neck": ("Neck",), "Head": ("Head",), "X_Hip": ("{s}UpLeg",), "X_Knee": ("{s}Leg",),
        "X_Ankle": ("{s}Foot",), "X_Foot": ("{s}ToeBase",), "X_Collar": ("{s}Shoulder",),
        "X_Shoulder": ("{s}Arm",), "X_Elbow": ("{s}ForeArm",), "X_Wrist": ("{s}Hand",),
        "X_Hand": ("{s}FingerBase", "{s}HandIndex1"),
    }, "Left", "Right"),
    "cmu-daz": _sided({
        "Pelvis": ("hip",), "Spine1": ("abdomen",), "Spine3": ("chest",), "Neck": ("neck",), "Head": ("head",),
        "X_Hip": ("{s}Thigh",), "X_Knee": ("{s}Shin",), "X_Ankle": ("{s}Foot",), "X_Collar": ("{s}Collar",),
        "X_Shoulder": ("{s}Shldr",), "X_Elbow": ("{s}ForeArm",), "X_Wrist": ("{s}Hand",), "X_Hand": ("{s}Mid1",),
    }, "l", "r"),
    "mixamo": _sided({
        "Pelvis": ("Hips",), "Spine1": ("Spine",), "Spine2": ("Spine1",), "Spine3": ("Spine2",),
        "Neck": ("Neck",), "Head": ("Head",), "X_Hip": ("{s}UpLeg",), "X_Knee": ("{s}Leg",),
        "X_Ankle": ("{s}Foot",), "X_Foot": ("{s}ToeBase",), "X_Collar": ("{s}Shoulder",),
        "X_Shoulder": ("{s}Arm",), "X_Elbow": ("{s}ForeArm",), "X_Wrist": ("{s}Hand",),
        "X_Hand": ("{s}HandMiddle1",),
    }, "Left", "Right"),
    "unreal": _sided({
        "Pelvis": ("pelvis",), "Spine1": ("spine_01",), "Spine2": ("spine_03", "spine_02"),
        "Spine3": ("spine_05", "spine_04", "spine_03"), "Neck": ("neck_01",), "Head": ("head",),
        "X_Hip": ("thigh_{s}",), "X_Knee": ("calf_{s}",), "X_Ankle": ("foot_{s}",), "X_Foot": ("ball_{s}",),
        "X_Collar": ("clavicle_{s}",), "X_Shoulder": ("upperarm_{s}",), "X_Elbow": ("lowerarm_{s}",),
        "X_Wrist": ("hand_{s}",), "X_Hand": ("middle_01_{s}",),
    }, "l", "r"),
}


def bare(name: str) -> str:
    """A joint name without its namespace prefix (``mixamorig:Hips`` -> ``Hips``, ``Armature|Hips`` -> ``Hips``)."""
    for sep in (":", "|"):
        name = name.rsplit(sep, 1)[-1]
    return name


@dataclass(frozen=True)
class RigMap:
    """Which joint index of one skeleton plays each canonical joint; ``name`` says where the map came from."""

    name: str
    joints: dict[str, int]

    def missing(self) -> list[str]:
        """Required canonical joints this rig lacks."""
        return [c for c in REQUIRED if c not in self.joints]

    def index(self, canonical: str) -> int | None:
        """The rig's joint for a canonical one, or None."""
        return self.joints.get(canonical)


def _lookup(skeleton: Skeleton | Sequence[str]) -> tuple[dict[str, int], dict[str, int]]:
    names = skeleton.names if isinstance(skeleton, Skeleton) else list(skeleton)
    exact = {bare(n): j for j, n in enumerate(names)}
    folded = {bare(n).lower(): j for j, n in enumerate(names)}
    return exact, folded


def apply_map(skeleton: Skeleton | Sequence[str], table: dict[str, tuple[str, ...]], name: str) -> RigMap:
    """A name table (canonical -> candidate rig names) resolved on a skeleton (or a list of joint
    names); absent joints are left out."""
    exact, folded = _lookup(skeleton)
    joints = {}
    for canonical, candidates in table.items():
        for cand in candidates:
            j = exact.get(bare(cand), folded.get(bare(cand).lower()))
            if j is not None:
                joints[canonical] = j
                break
    return RigMap(name, joints)


def detect_map(skeleton: Skeleton | Sequence[str], where: str = "") -> RigMap:
    """The built-in map that covers the most of the skeleton's (or joint-name list's) required joints;
    a one-line error naming the missing joints and the presets when none covers them all."""
    maps = [apply_map(skeleton, table, name) for name, table in PRESETS.items()]
    best = min(maps, key=lambda m: (len(m.missing()), -len(m.joints)))
    if best.missing():
        label = where or getattr(skeleton, "name", "joints")
        raise DataError(f"{label}: cannot map the rig's joints onto a body: closest preset "
                        f"{best.name!r} lacks {', '.join(best.missing())} (presets: {', '.join(PRESETS)}; "
                        "or give a YAML joint map)")
    return best


#: the largest joint-map file read (a map of a few hundred joints is a few kB)
MAX_MAP_BYTES = 64_000


def load_map(path: str | Path) -> dict[str, tuple[str, ...]]:
    """A user's YAML joint map: ``canonical name: rig joint name`` (or a list of candidates) per line,
    or a ``preset:`` plus ``joints:`` to override some of a built-in map."""
    from dance_core.recipe.yaml_source import parse_text

    path = Path(path)
    try:
        if path.stat().st_size > MAX_MAP_BYTES:
            raise DataError(f"{path}: a joint map is at most {MAX_MAP_BYTES} bytes")
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataError(f"{path}: joint map not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: cannot read the joint map: {getattr(exc, 'strerror', None) or exc}") from None
    data = parse_text(text, str(path)).data
    if not isinstance(data, dict):
        raise DataError(f"{path}: a joint map is a YAML mapping of canonical joint names to rig joint names")
    table: dict[str, tuple[str, ...]] = {}
    if "preset" in data or "joints" in data:
        preset = data.get("preset")
        if preset is not None:
            if preset not in PRESETS:
                raise DataError(f"{path}: preset: unknown {preset!r} (presets: {', '.join(PRESETS)})")
            table.update(PRESETS[preset])
        data = data.get("joints") or {}
        if not isinstance(data, dict):
            raise DataError(f"{path}: joints: must be a mapping of canonical joint names to rig joint names")
    for key, value in data.items():
        if key not in SMPL_NAMES:
            raise DataError(f"{path}: {key!r} is not a canonical joint (one of: {', '.join(SMPL_NAMES)})")
        names = (value,) if isinstance(value, str) else value
        if not isinstance(names, (list, tuple)) or not names or not all(isinstance(n, str) and n for n in names):
            raise DataError(f"{path}: {key}: must be a joint name or a list of joint names")
        table[key] = tuple(names)
    return table


def rig_map(skeleton: Skeleton, spec: str | Path | None = None, where: str = "") -> RigMap:
    """The map of a skeleton: detected among the presets (``spec`` None), a preset by name, or a YAML
    file; a one-line error naming the missing joints when the required ones are not all there."""
    if spec is None:
        return detect_map(skeleton, where)
    if str(spec) in PRESETS:
        found = apply_map(skeleton, PRESETS[str(spec)], str(spec))
    else:
        found = apply_map(skeleton, load_map(spec), Path(spec).name)
    if found.missing():
        raise DataError(f"{where or skeleton.name}: joint map {found.name!r} finds no joint for "
                        f"{', '.join(found.missing())} (presets: {', '.join(PRESETS)})")
    return found


def renamed(skeleton: Skeleton, preset: str, prefix: str = "") -> Skeleton:
    """A copy of a skeleton with SMPL-24 joint names whose joints carry a preset's names instead (the
    first candidate, after ``prefix``, e.g. ``mixamorig:``); joints the preset lacks keep their names."""
    from dataclasses import replace

    if preset not in PRESETS:
        raise DataError(f"unknown joint-map preset {preset!r} (presets: {', '.join(PRESETS)})")
    table = PRESETS[preset]
    names = [prefix + table[n][0] if n in table else n for n in skeleton.names]
    return replace(skeleton, names=names, name=f"{skeleton.name}-{preset}")


def arms_lowered(skeleton: Skeleton, degrees: float = 45.0) -> Skeleton:
    """A copy of a skeleton with SMPL-24 joint names (a T-pose) with both arms lowered by ``degrees`` at
    rest: the offsets and End Sites from the elbow down turned about the body's forward axis (an A-pose
    rig, as many characters are modelled)."""
    from dataclasses import replace

    import numpy as np

    from dance_core.motion.rotations import expmap_to_quat, quat_rotate

    offsets, ends = skeleton.offsets.copy(), dict(skeleton.end_sites)
    for side, sign in (("L", 1.0), ("R", -1.0)):
        turn = expmap_to_quat(np.array([0.0, 0.0, -sign * np.radians(degrees)]))
        for part in ("Elbow", "Wrist", "Hand"):
            j = skeleton.index(f"{side}_{part}")
            offsets[j] = quat_rotate(turn, offsets[j])
            if j in ends:
                ends[j] = quat_rotate(turn, ends[j])
    return replace(skeleton, offsets=offsets, end_sites=ends, name=f"{skeleton.name}-apose")
