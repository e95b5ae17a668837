"""Put another skeleton of the same joints into a checkpoint's metadata, leaving its weights untouched.

A dance checkpoint's ``motion`` metadata (JSON) records the skeleton its motion representation decodes
onto: joint names, parents, rest offsets, End Sites. A model of the ``rotations`` representation outputs
joint rotations (expmap) and root deltas, never offsets, so its weights serve any skeleton with the same
joints in the same order. This script swaps the stored skeleton for another of the same tree (by default
our ``dance24``), and with it what the checkpoint's dances are decoded and written on (BVH offsets,
forward kinematics).

    .venv/bin/python packages/dance-core/scripts/reskeleton_checkpoint.py CHECKPOINT.safetensors [...]
    .venv/bin/python packages/dance-core/scripts/reskeleton_checkpoint.py --check CHECKPOINT.safetensors

Only the ``skeleton`` entry of the ``motion`` metadata changes. The tensors (weights and normalization
statistics) are read with safetensors and written back byte for byte (checked after writing against the
original file); the other metadata entries are kept as they were. The file is written atomically by
``dance_core.checkpoint.write_safetensors``, the writer of every dance checkpoint (sorted header, the same
bytes for the same content). A skeleton whose joint names or parents differ is refused: the weights'
rotation channels follow the joint order. ``--check`` writes nothing and exits 1 when a file still holds
another skeleton. Running it again on a converted file changes nothing.
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
from pathlib import Path

from safetensors import safe_open
from safetensors.torch import load_file

from dance_core.atomic import atomic_path
from dance_core.checkpoint import write_safetensors
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import dance24


def _tensor_bytes(path: Path) -> dict[str, bytes]:
    """Each tensor's raw bytes as stored in a safetensors file (from the header's data offsets)."""
    data = path.read_bytes()
    (n,) = struct.unpack("<Q", data[:8])
    header = json.loads(data[8 : 8 + n])
    base = 8 + n
    return {k: data[base + v["data_offsets"][0] : base + v["data_offsets"][1]]
            for k, v in header.items() if k != "__metadata__"}


def _dumps_like(value: dict, original: str) -> str:
    """JSON in the original string's style (sorted keys when it had them; dance's writer sorts)."""
    sort = json.dumps(json.loads(original), sort_keys=True) == original
    return json.dumps(value, sort_keys=sort)


def reskeleton(path: Path, skeleton: Skeleton, check: bool = False) -> str:
    """Swap the skeleton stored in one checkpoint; a line saying what was done."""
    with safe_open(str(path), framework="pt") as f:
        metadata = dict(f.metadata() or {})
    if "motion" not in metadata:
        raise SystemExit(f"{path}: no motion metadata (not a dance checkpoint?)")
    motion = json.loads(metadata["motion"])
    old = Skeleton.from_dict(motion["skeleton"])
    new = skeleton.to_dict()
    if motion["skeleton"] == new:
        return f"{path}: already on {skeleton.name}"
    if not old.same_topology(skeleton):
        raise SystemExit(f"{path}: stored skeleton {old.name!r} has other joints or parents than {skeleton.name!r}; "
                         "the weights' rotation channels would not fit it")
    if check:
        return f"{path}: holds skeleton {old.name!r}, not {skeleton.name!r}"
    before = _tensor_bytes(path)
    tensors = load_file(str(path))
    motion["skeleton"] = new
    metadata["motion"] = _dumps_like(motion, metadata["motion"])
    with atomic_path(path) as tmp:
        write_safetensors(tmp, tensors, metadata)
        if _tensor_bytes(Path(tmp)) != before:  # the rename happens only when every tensor is unchanged
            raise SystemExit(f"{path}: tensors would change; nothing written")
    return f"{path}: skeleton {old.name!r} -> {skeleton.name!r}; {len(before)} tensors byte-identical"


def main(argv: list[str] | None = None) -> int:
    """Command line: checkpoints to convert (or ``--check``)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoints", nargs="+", type=Path)
    parser.add_argument("--check", action="store_true", help="only report; exit 1 when one holds another skeleton")
    args = parser.parse_args(argv)
    skeleton = dance24()
    lines = [reskeleton(p, skeleton, check=args.check) for p in args.checkpoints]
    print("\n".join(lines))
    return 1 if args.check and any(" holds skeleton " in line for line in lines) else 0


if __name__ == "__main__":
    sys.exit(main())
