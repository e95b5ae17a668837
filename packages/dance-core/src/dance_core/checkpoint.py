"""Checkpoints: weights, normalization statistics and the resolved recipe in one safetensors file.

The files are written by :func:`write_safetensors`, byte for byte the same for the same tensors and
metadata (sorted header keys, no time or path), and read back with the ``safetensors`` library.
"""

from __future__ import annotations

import json
import struct
import sys
from dataclasses import dataclass
from importlib.metadata import distributions
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors import SafetensorError
from safetensors.torch import load_file

from dance_core.atomic import atomic_path
from dance_core.data.motion_info import MotionInfo
from dance_core.data.stats import NormStats
from dance_core.errors import CheckpointError, DataError
from dance_core.recipe.schema import Recipe

FORMAT = "dance-checkpoint/1"
STATE_FORMAT = "dance-train-state/1"


_DTYPES = {
    torch.float64: "F64", torch.float32: "F32", torch.float16: "F16", torch.bfloat16: "BF16",
    torch.int64: "I64", torch.int32: "I32", torch.int16: "I16", torch.int8: "I8", torch.uint8: "U8",
    torch.bool: "BOOL",
}


def versions() -> dict[str, str]:
    """Versions of torch and every installed dance distribution, sorted by name."""
    found = {"torch": torch.__version__}
    for dist in distributions():
        name = dist.metadata["name"] or ""
        if name.startswith("dance-"):
            found[name] = dist.version
    return dict(sorted(found.items()))


def _dumps(value: Any) -> str:
    """JSON for metadata: sorted keys, so equal values give equal bytes."""
    return json.dumps(value, sort_keys=True)


def write_safetensors(path: str | Path, tensors: dict[str, torch.Tensor], metadata: dict[str, str]) -> None:
    """Write a safetensors file deterministically: the header's keys sorted, tensors ordered by
    element size then name (every tensor aligned), the header padded to 8 bytes."""
    if sys.byteorder != "little":  # pragma: no cover - safetensors stores little-endian data
        raise CheckpointError(f"{path}: writing checkpoints needs a little-endian machine")
    for name, t in tensors.items():
        if t.dtype not in _DTYPES:
            raise CheckpointError(f"{path}: tensor {name!r} has unsupported dtype {t.dtype}")
    order = sorted(tensors, key=lambda k: (-tensors[k].element_size(), k))
    header: dict[str, Any] = {"__metadata__": {str(k): str(v) for k, v in metadata.items()}}
    offset = 0
    for name in order:
        t = tensors[name]
        size = t.numel() * t.element_size()
        header[name] = {"dtype": _DTYPES[t.dtype], "shape": list(t.shape), "data_offsets": [offset, offset + size]}
        offset += size
    blob = json.dumps(header, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    blob += b" " * (-(8 + len(blob)) % 8)
    with open(path, "wb") as fh:
        fh.write(struct.pack("<Q", len(blob)))
        fh.write(blob)
        for name in order:
            flat = tensors[name].detach().to("cpu").contiguous().reshape(-1)
            fh.write(flat.view(torch.uint8).numpy().tobytes())


def _save(path: Path, tensors: dict[str, torch.Tensor], metadata: dict[str, str]) -> None:
    tensors = {k: v.detach().to("cpu").contiguous().clone() for k, v in tensors.items()}
    with atomic_path(path) as tmp:
        write_safetensors(tmp, tensors, metadata)


def _metadata(path: Path, what: str) -> dict[str, str]:
    if not path.exists():
        raise CheckpointError(f"{path}: {what} not found")
    if path.is_dir():
        inside = path / "model.safetensors"
        hint = f" (the run's checkpoint is {inside})" if inside.is_file() else ""
        raise CheckpointError(f"{path}: is a folder, not a {what} file{hint}")
    try:
        from safetensors import safe_open

        with safe_open(str(path), framework="pt") as f:
            return f.metadata() or {}
    except (SafetensorError, OSError, ValueError) as exc:
        raise CheckpointError(f"{path}: not a readable safetensors {what}: {exc}") from None


def _load(path: Path, what: str) -> tuple[dict[str, torch.Tensor], dict[str, str]]:
    metadata = _metadata(path, what)
    try:
        tensors = load_file(str(path))
    except (SafetensorError, OSError, ValueError) as exc:
        raise CheckpointError(f"{path}: not a readable safetensors {what}: {exc}") from None
    return tensors, metadata


@dataclass
class Checkpoint:
    """A loaded model checkpoint."""

    path: Path
    weights: dict[str, torch.Tensor]
    stats: NormStats
    recipe: dict[str, Any]
    motion: MotionInfo
    versions: dict[str, str]
    step: int
    run: str | None = None  #: the training run's id (None in checkpoints written before run ids)


def save_checkpoint(
    path: str | Path,
    model: torch.nn.Module,
    stats: NormStats,
    recipe: Recipe,
    motion: MotionInfo,
    step: int,
    run: str | None = None,
) -> None:
    """Write weights, statistics and metadata atomically (``run``: the training run's id)."""
    tensors = {f"model.{k}": v for k, v in model.state_dict().items()}
    tensors.update({k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in stats.to_arrays().items()})
    metadata = {
        "format": FORMAT,
        "recipe": _dumps(recipe.model_dump(mode="json")),
        "motion": _dumps(motion.to_dict()),
        "versions": _dumps(versions()),
        "step": str(step),
    }
    if run is not None:
        metadata["run"] = run
    _save(Path(path), tensors, metadata)


def _typed(value: Any, kind: type, field: str) -> Any:
    """``value`` when it is a ``kind`` (metadata is JSON the file chose); else a ``TypeError`` naming the field."""
    if not isinstance(value, kind):
        raise TypeError(f"{field} is a {type(value).__name__}, not a {kind.__name__}")
    return value


def _step(text: Any) -> int:
    """A step count from metadata: digits only, at most 18 of them."""
    if not isinstance(text, str) or not (text.isascii() and text.isdigit()) or len(text) > 18:
        raise ValueError(f"step {str(text)[:20]!r} is not a step count")
    return int(text)


def load_checkpoint(path: str | Path) -> Checkpoint:
    """Read a checkpoint written by :func:`save_checkpoint` (safetensors only, never pickle)."""
    path = Path(path)
    tensors, meta = _load(path, "checkpoint")
    if meta.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not a dance checkpoint (format {meta.get('format')!r})")
    try:
        recipe = _typed(json.loads(meta["recipe"]), dict, "recipe")
        motion = MotionInfo.from_dict(_typed(json.loads(meta["motion"]), dict, "motion"))
        found = _typed(json.loads(meta.get("versions", "{}")), dict, "versions")
        step = _step(meta.get("step", "0"))
        stats = NormStats.from_arrays({k: v.numpy() for k, v in tensors.items() if k.startswith("norm.")})
    except (KeyError, ValueError, TypeError, AttributeError, DataError) as exc:
        raise CheckpointError(f"{path}: corrupt checkpoint metadata ({type(exc).__name__}: {exc})") from None
    weights = {k[len("model.") :]: v for k, v in tensors.items() if k.startswith("model.")}
    return Checkpoint(path, weights, stats, recipe, motion, found, step, meta.get("run"))


def _diff(a: Any, b: Any, loc: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in sorted(set(a) | set(b), key=str):
            out += _diff(a.get(key), b.get(key), f"{loc}.{key}" if loc else str(key))
        return out
    return [] if a == b else [loc]


def check_matches(ckpt: Checkpoint, recipe: Recipe) -> None:
    """Refuse a recipe whose fps, features or model differ from the checkpoint's."""
    differ = _diff(recipe.model_dict(ckpt.recipe), recipe.model_dict())
    if differ:
        shown = ", ".join(differ[:4]) + (f" and {len(differ) - 4} more" if len(differ) > 4 else "")
        raise CheckpointError(f"{ckpt.path}: checkpoint does not match recipe {recipe.origin}: {shown} differ")


def load_weights(model: torch.nn.Module, ckpt: Checkpoint) -> None:
    """Load weights strictly; a mismatch names the checkpoint and the first differing tensor."""
    own = model.state_dict()
    missing = sorted(set(own) - set(ckpt.weights))
    extra = sorted(set(ckpt.weights) - set(own))
    shapes = [k for k in own if k in ckpt.weights and own[k].shape != ckpt.weights[k].shape]
    if missing or extra or shapes:
        if missing:
            detail = f"missing {missing[0]}"
        elif extra:
            detail = f"unexpected {extra[0]}"
        else:
            got, want = tuple(ckpt.weights[shapes[0]].shape), tuple(own[shapes[0]].shape)
            detail = f"{shapes[0]} has shape {got}, model wants {want}"
        raise CheckpointError(f"{ckpt.path}: weights do not fit the recipe's model ({detail})")
    model.load_state_dict(ckpt.weights)


def save_train_state(path: str | Path, optimizer: torch.optim.Optimizer, step: int, run: str | None = None) -> None:
    """Optimizer and RNG state for an exact resume, with the step and run id of the checkpoint it goes with."""
    tensors: dict[str, torch.Tensor] = {"rng.torch": torch.get_rng_state()}
    if torch.cuda.is_available():
        for i, state in enumerate(torch.cuda.get_rng_state_all()):
            tensors[f"rng.cuda.{i}"] = state
    sd = optimizer.state_dict()
    plain: dict[str, dict[str, Any]] = {}
    for pid, state in sd["state"].items():
        for key, value in state.items():
            if torch.is_tensor(value):
                tensors[f"opt.{pid}.{key}"] = value
            else:
                plain.setdefault(str(pid), {})[key] = value
    metadata = {
        "format": STATE_FORMAT,
        "step": str(step),
        "param_groups": _dumps(sd["param_groups"]),
        "plain_state": _dumps(plain),
    }
    if run is not None:
        metadata["run"] = run
    _save(Path(path), tensors, metadata)


def train_state_info(path: str | Path) -> tuple[int, str | None]:
    """The step and run id a training state was saved at (its metadata only; no tensor is read)."""
    path = Path(path)
    meta = _metadata(path, "training state")
    if meta.get("format") != STATE_FORMAT:
        raise CheckpointError(f"{path}: not a dance training state")
    try:
        return _step(meta["step"]), meta.get("run")
    except (KeyError, ValueError):
        raise CheckpointError(f"{path}: corrupt training state metadata (step)") from None


def load_train_state(path: str | Path, optimizer: torch.optim.Optimizer | None) -> int:
    """Restore RNG and (unless None, as at a stage boundary) optimizer state; returns the step."""
    path = Path(path)
    tensors, meta = _load(path, "training state")
    if meta.get("format") != STATE_FORMAT:
        raise CheckpointError(f"{path}: not a dance training state")
    state: dict[int, dict[str, Any]] = {}
    for key, value in tensors.items():
        if key.startswith("opt."):
            _, pid, name = key.split(".", 2)
            state.setdefault(int(pid), {})[name] = value
    for pid, values in json.loads(meta["plain_state"]).items():
        state.setdefault(int(pid), {}).update(values)
    try:
        if optimizer is not None:
            optimizer.load_state_dict({"state": state, "param_groups": json.loads(meta["param_groups"])})
    except (ValueError, KeyError) as exc:
        raise CheckpointError(f"{path}: training state does not fit the model: {exc}") from None
    torch.set_rng_state(tensors["rng.torch"])
    if torch.cuda.is_available():
        cuda = [tensors[k] for k in sorted(k for k in tensors if k.startswith("rng.cuda."))]
        if cuda:
            torch.cuda.set_rng_state_all(cuda)
    return int(meta["step"])
