"""Checkpoints: weights, normalization statistics and the resolved recipe in one safetensors file."""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib.metadata import distributions
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

from dance_core.atomic import atomic_path
from dance_core.data.stats import NormStats
from dance_core.errors import CheckpointError
from dance_core.recipe.schema import Recipe

FORMAT = "dance-checkpoint/1"
STATE_FORMAT = "dance-train-state/1"


def versions() -> dict[str, str]:
    """Versions of torch and every installed dance distribution."""
    found = {"torch": torch.__version__}
    for dist in distributions():
        name = dist.metadata["name"] or ""
        if name.startswith("dance-"):
            found[name] = dist.version
    return found


def _save(path: Path, tensors: dict[str, torch.Tensor], metadata: dict[str, str]) -> None:
    tensors = {k: v.detach().to("cpu").contiguous().clone() for k, v in tensors.items()}
    with atomic_path(path) as tmp:
        save_file(tensors, str(tmp), metadata=metadata)


def _load(path: Path, what: str) -> tuple[dict[str, torch.Tensor], dict[str, str]]:
    if not path.exists():
        raise CheckpointError(f"{path}: {what} not found")
    try:
        from safetensors import safe_open

        with safe_open(str(path), framework="pt") as f:
            metadata = f.metadata() or {}
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
    motion: dict[str, Any]
    versions: dict[str, str]
    step: int


def save_checkpoint(
    path: str | Path,
    model: torch.nn.Module,
    stats: NormStats,
    recipe: Recipe,
    motion: dict[str, Any],
    step: int,
) -> None:
    """Write weights, statistics and metadata atomically."""
    tensors = {f"model.{k}": v for k, v in model.state_dict().items()}
    tensors.update({k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in stats.to_arrays().items()})
    metadata = {
        "format": FORMAT,
        "recipe": json.dumps(recipe.model_dump(mode="json")),
        "motion": json.dumps(motion),
        "versions": json.dumps(versions()),
        "step": str(step),
    }
    _save(Path(path), tensors, metadata)


def load_checkpoint(path: str | Path) -> Checkpoint:
    """Read a checkpoint written by :func:`save_checkpoint` (safetensors only, never pickle)."""
    path = Path(path)
    tensors, meta = _load(path, "checkpoint")
    if meta.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not a dance checkpoint (format {meta.get('format')!r})")
    try:
        recipe = json.loads(meta["recipe"])
        motion = json.loads(meta["motion"])
        found = json.loads(meta.get("versions", "{}"))
        step = int(meta.get("step", "0"))
        stats = NormStats.from_arrays({k: v.numpy() for k, v in tensors.items() if k.startswith("norm.")})
    except (KeyError, ValueError) as exc:
        raise CheckpointError(f"{path}: corrupt checkpoint metadata ({exc})") from None
    weights = {k[len("model.") :]: v for k, v in tensors.items() if k.startswith("model.")}
    return Checkpoint(path, weights, stats, recipe, motion, found, step)


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
        raise CheckpointError(f"{ckpt.path}: checkpoint does not match recipe {recipe._origin}: {shown} differ")


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


def save_train_state(path: str | Path, optimizer: torch.optim.Optimizer, step: int) -> None:
    """Optimizer and RNG state for an exact resume."""
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
        "param_groups": json.dumps(sd["param_groups"]),
        "plain_state": json.dumps(plain),
    }
    _save(Path(path), tensors, metadata)


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
