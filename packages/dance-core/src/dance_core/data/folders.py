"""Datasets on disk: a paired folder, the AIST++ layout and HumanML3D.

Each yields ``ClipSource``s with the audio as a path (read, or taken from the feature cache, when
training prepares clips), the motion as read by its registered format, and timed text if any.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from dance_core.contexts import DEFAULT_FORMATS, FormatOptions
from dance_core.data.files import pair_folder, read_motion_file, read_texts
from dance_core.data.sources import ClipSource
from dance_core.errors import DataError
from dance_core.media import TextSpan
from dance_core.registry import get_registry

AIST_MUSIC = re.compile(r"_(m[A-Z]{2}\d)_")


def _root(path: str, root: str) -> Path:
    p = Path(path).expanduser()
    return p if p.is_absolute() else Path(root) / p


class FolderDataset:
    """``name.wav|.ogg|.mp3`` + ``name.bvh|.pkl|.npz|...`` pairs, optional ``name.texts``."""

    def __init__(self, config: Any, root: str = ".", formats: FormatOptions = DEFAULT_FORMATS):
        self.config = config
        self.folder = _root(config.path, root)
        self.cache = str(_root(config.cache, root)) if config.cache else str(self.folder / ".dance-cache")
        self.formats = formats

    def clips(self) -> list[ClipSource]:
        """Every pair in the folder."""
        registry = get_registry()
        out = []
        for name, audio, motion in pair_folder(self.folder, registry):
            texts_file = motion.with_suffix(".texts")
            texts = read_texts(texts_file) if texts_file.exists() else ()
            meta = {"feature_cache": self.cache, "max_offset": self.config.max_offset}
            out.append(ClipSource(name, read_motion_file(motion, registry, formats=self.formats),
                                  audio_path=str(audio), texts=texts, meta=meta))
        return out


class AistDataset:
    """AIST++: ``motions/<seq>.pkl`` (SMPL at 60 fps), ``wav/<music id>.wav``, ``splits/<split>.txt``;
    the music id is parsed from the sequence name (``gBR_sBM_cAll_d04_mBR0_ch01`` dances to ``mBR0``)."""

    def __init__(self, config: Any, root: str = "."):
        self.config = config
        self.root = root
        self.folder = _root(config.path, root)

    def names(self) -> list[str]:
        """Sequence names of the split (all motions when ``split`` is None), minus ``ignore_list.txt``."""
        motions = self.folder / "motions"
        if not motions.is_dir():
            raise DataError(f"{motions}: AIST++ motions folder not found")
        if self.config.split:
            split = self.folder / "splits" / f"{self.config.split}.txt"
            if not split.exists():
                raise DataError(f"{split}: AIST++ split list not found (data.dataset.split)")
            names = [ln.strip() for ln in split.read_text().splitlines() if ln.strip()]
        else:
            names = sorted(p.stem for p in motions.glob("*.pkl"))
        ignore = self.folder / "ignore_list.txt"
        skip = set(ignore.read_text().split()) if ignore.exists() else set()
        return [n for n in names if n not in skip]

    def clips(self) -> list[ClipSource]:
        """Every sequence of the split with its music (motion on the recipe's or the environment's SMPL model)."""
        from dance_core.formats.smpl import SmplFormat
        from dance_core.formats.smpl_model import missing_model, model_from_env

        model = str(_root(self.config.smpl_model, self.root)) if self.config.smpl_model else model_from_env()
        if model is None:  # one line before any file is read
            raise missing_model(self.folder / "motions")
        smpl = SmplFormat(model=model)
        out = []
        for name in self.names():
            music = AIST_MUSIC.search(name)
            if music is None:
                raise DataError(f"{self.folder}: sequence {name!r} has no music id (_mXX0_) in its name")
            wav = self.folder / "wav" / f"{music.group(1)}.wav"
            pkl = self.folder / "motions" / f"{name}.pkl"
            if not pkl.exists():
                raise DataError(f"{pkl}: motion listed in the split but missing")
            if not wav.exists():
                raise DataError(f"{pkl}: no audio partner ({wav} not found)")
            meta = {"feature_cache": str(self.folder / ".dance-cache"), "max_offset": self.config.max_offset,
                    "music": music.group(1)}
            motion = smpl.read(str(pkl))
            motion.meta.setdefault("path", str(pkl))
            out.append(ClipSource(name, motion, audio_path=str(wav), meta=meta))
        return out


class HumanMLDataset:
    """HumanML3D: ``new_joints/<id>.npy`` (T, 22, 3) at 20 fps, ``texts/<id>.txt`` with lines
    ``caption#tokens#start#end`` (0 and 0 meaning the whole clip), ``<split>.txt`` id lists. No music."""

    def __init__(self, config: Any, root: str = "."):
        self.config = config
        self.folder = _root(config.path, root)

    def clips(self) -> list[ClipSource]:
        """Every clip of the split with its captions as text spans."""
        from dance_core.formats.joints import JointsFormat

        joints = self.folder / "new_joints"
        if not joints.is_dir():
            raise DataError(f"{joints}: HumanML3D new_joints folder not found")
        if self.config.split:
            split = self.folder / f"{self.config.split}.txt"
            if not split.exists():
                raise DataError(f"{split}: HumanML3D split list not found (data.dataset.split)")
            ids = [ln.strip() for ln in split.read_text().splitlines() if ln.strip()]
        else:
            ids = sorted(p.stem for p in joints.glob("*.npy"))
        fmt = JointsFormat(self.config.fps)
        out = []
        for i in ids:
            data = fmt.read(joints / f"{i}.npy")
            texts = self.captions(self.folder / "texts" / f"{i}.txt", data.values.shape[0] / data.fps)
            out.append(ClipSource(i, data, texts=texts, meta={"captions": [t.text for t in texts]}))
        return out

    @staticmethod
    def captions(path: Path, seconds: float) -> tuple[TextSpan, ...]:
        """Text spans from a HumanML3D caption file (a missing file is an error naming it)."""
        if not path.exists():
            raise DataError(f"{path}: HumanML3D captions not found")
        spans = []
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if not line.strip():
                continue
            parts = line.split("#")
            try:
                start, end = float(parts[2]), float(parts[3])
            except (IndexError, ValueError):
                raise DataError(f"{path}:{n}: expected caption#tokens#start#end") from None
            whole = start == 0.0 and end == 0.0
            spans.append(TextSpan(parts[0].strip(), 0.0 if whole else start, None if whole else min(end, seconds)))
        return tuple(spans)


def build_folder(config: Any, *, root: str = ".", formats: FormatOptions = DEFAULT_FORMATS, **_: Any) -> FolderDataset:
    """Build the ``folder`` dataset (its motion files read with the recipe's ``formats:`` options)."""
    return FolderDataset(config, root, formats)


def build_aist(config: Any, *, root: str = ".", **_: Any) -> AistDataset:
    """Build the ``aist`` dataset."""
    return AistDataset(config, root)


def build_humanml(config: Any, *, root: str = ".", **_: Any) -> HumanMLDataset:
    """Build the ``humanml3d`` dataset."""
    return HumanMLDataset(config, root)
