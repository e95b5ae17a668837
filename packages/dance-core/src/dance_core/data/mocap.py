"""The ``mocap`` dataset: a folder of real motion-capture takes of any rig, as music-less clips.

Each take is read with its registered motion format, retargeted onto the dataset's skeleton
(:mod:`dance_core.motion.retarget`: joint maps, rest poses, leg-length scale, feet on the floor) and
resampled to the recipe's frame rate. The result is cached on disk like features: keyed by the file's
content hash and everything that shapes the result, as ``.npz`` without pickles, so a second run reads
no BVH. Clips carry silent audio as long as the motion, as :mod:`dance_core.synth.synthetic_moves` does:
music extractors run unchanged and silence says "no music", so the clips teach a motion prior (TM2D's
tokenizer) or mix with music-dance pairs (:mod:`dance_core.data.mix`).
"""

from __future__ import annotations

import fnmatch
import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.contexts import DEFAULT_FORMATS, FormatOptions
from dance_core.data.cache import FeatureCache, file_digest
from dance_core.data.files import motion_files, read_motion_file
from dance_core.data.sources import ClipSource
from dance_core.errors import DataError
from dance_core.media import Audio
from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton
from dance_core.protocols import MotionData
from dance_core.registry import get_registry

#: bump when retargeting changes what a cached take holds (2: the grounding after retargeting keeps the knees'
#: bend, ``grounding.knee_drop``; takes cached before it had knees about 2 degrees straighter)
VERSION = 2


def default_cache() -> Path:
    """``$XDG_CACHE_HOME/dance/mocap`` (``~/.cache/dance/mocap``)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "dance" / "mocap"


def _resolve(path: str, root: str) -> Path:
    p = Path(path).expanduser()
    return p if p.is_absolute() else Path(root) / p


def target_skeleton(spec: str, root: str = ".", formats: FormatOptions = DEFAULT_FORMATS) -> Skeleton:
    """A built-in skeleton by name, or the skeleton of a motion file."""
    from dance_core.motion import skeletons

    if spec in ("dance24", "transflower21"):
        return getattr(skeletons, spec)()
    path = _resolve(spec, root)
    if not path.is_file():
        raise DataError(f"{path}: data.dataset.skeleton: no such motion file (or give dance24 or transflower21)")
    data = read_motion_file(path, get_registry(), formats=formats)
    if data.skeleton_motion is None:
        raise DataError(f"{path}: data.dataset.skeleton: the file has no skeleton")
    return data.skeleton_motion.skeleton


class MocapDataset:
    """Takes of a folder retargeted onto one skeleton at one frame rate (see the module's note)."""

    def __init__(self, config: Any, fps: float, root: str = ".", formats: FormatOptions = DEFAULT_FORMATS):
        self.config = config
        self.formats = formats
        self.fps = config.motion_fps or fps
        self.root = root
        self.folder = _resolve(config.path, root)
        self.cache = FeatureCache(_resolve(config.cache, root) if config.cache else default_cache())

    def files(self) -> list[Path]:
        """The takes: readable motion files of the folder matching ``files`` and not ``exclude``."""
        found = motion_files(self.folder, get_registry())
        wanted = self.config.files
        keep = [p for p in found if (not wanted or any(fnmatch.fnmatch(p.name, w) for w in wanted))
                and not any(fnmatch.fnmatch(p.name, x) for x in self.config.exclude)]
        if not keep:
            raise DataError(f"{self.folder}: no motion files match data.dataset.files/exclude")
        return keep

    def clips(self) -> list[ClipSource]:
        """Every take as a music-less clip on the dataset's skeleton."""
        from dance_core.motion.retarget import rig_frames

        target = target_skeleton(self.config.skeleton, self.root, self.formats)
        rig_frames(target, None, self.config.skeleton)  # a target that cannot be mapped fails before any take
        source_map = self.config.source_map
        if source_map is not None and not _is_preset(source_map):
            source_map = str(_resolve(source_map, self.root))
        settings = {"v": VERSION, "skeleton": target.to_dict(), "fps": self.fps, "map": source_map,
                    "map_file": file_digest(source_map) if source_map and Path(source_map).is_file() else None,
                    "ground": self.config.ground}
        read = {f"{kind}:{name}": config.model_dump(mode="json")
                for (kind, name), config in sorted(self.formats.configs.items()) if kind == "motion-format"}
        if read:  # only then: caches written without format options keep their keys
            settings["formats"] = read
        digest = hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]
        return [self.clip(path, target, source_map, digest) for path in self.files()]

    def clip(self, path: Path, target: Skeleton, source_map: str | None, digest: str) -> ClipSource:
        """One take, from the cache or retargeted now."""
        key = f"{file_digest(path)[:32]}-{digest}"
        cached = self.cache.get(key)
        if cached is not None and {"root", "rotations"} <= set(cached):
            motion = Motion(target, self.fps, cached["root"], cached["rotations"])
        else:
            motion = self.retarget(path, target, source_map)
            self.cache.put(key, {"root": motion.root, "rotations": motion.rotations})
        seconds = motion.n_frames / motion.fps
        rate = self.config.sample_rate
        audio = Audio(np.zeros(int(np.ceil(round(seconds * rate, 6))), np.float32), rate)
        meta = {"path": str(path), "take": path.stem, "style": "silence", "beats": [], "sections": []}
        positions = motion.positions().reshape(motion.n_frames, -1).astype(np.float32)
        channels = [f"{j}.{a}" for j in target.names for a in "xyz"]
        return ClipSource(path.stem, MotionData(positions, motion.fps, channels, dict(meta), motion), audio,
                          meta=meta)

    def retarget(self, path: Path, target: Skeleton, source_map: str | None) -> Motion:
        """Read one take and retarget it onto the target at the dataset's frame rate."""
        from dance_core.motion.retarget import retarget

        data = read_motion_file(path, get_registry(), formats=self.formats)
        take = data.skeleton_motion
        if take is None or take.rotations is None:
            raise DataError(f"{path}: a mocap take needs joint rotations (a skeletal motion file)")
        moved, _ = retarget(take, target, source_map, None, ground=self.config.ground, where=str(path))
        return moved.resample(self.fps)


def _is_preset(spec: str) -> bool:
    from dance_core.motion.rig_maps import PRESETS

    return spec in PRESETS


def build(
    config: Any, *, fps: float, root: str = ".", formats: FormatOptions = DEFAULT_FORMATS, **_: Any
) -> MocapDataset:
    """Build the ``mocap`` dataset (takes read with the recipe's ``formats:`` options)."""
    return MocapDataset(config, fps, root, formats)
