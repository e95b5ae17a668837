"""The skeleton type: joint names, parents, rest offsets, BVH channel layout, end sites and units."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dance_core.errors import DataError

ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
JOINT_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
_SIDES = (("Left", "Right"), ("left", "right"), ("L_", "R_"), ("l_", "r_"))


def _swapped(name: str) -> list[str]:
    """Candidate mirror names: Left<->Right anywhere, or a leading single L/R (``LHipJoint``)."""
    out = [name.replace(a, b, 1) for x, y in _SIDES for a, b in ((x, y), (y, x)) if a in name]
    if name[:1] in ("L", "R") and name[1:2].isupper():
        out.append(("R" if name[0] == "L" else "L") + name[1:])
    return [c for c in out if c != name]


def side_of(name: str, names: list[str]) -> str | None:
    """``"left"`` or ``"right"`` for a joint whose mirror counterpart is among ``names``, else None."""
    if not any(c in names for c in _swapped(name)):
        return None
    left = any(t in name for t in ("Left", "left", "L_", "l_")) or (name[:1] == "L" and name[1:2].isupper())
    return "left" if left else "right"


@dataclass
class Skeleton:
    """A kinematic tree in depth-first order (every parent comes before its children).

    ``offsets[j]`` is joint ``j``'s rest position relative to its parent (the root's is its rest
    position). ``channels[j]`` is the BVH channel list used when writing; ``end_sites`` maps a joint
    to the offset of its BVH End Site. ``units`` is informational (``"cm"``, ``"m"``, ...).
    """

    names: list[str]
    parents: list[int]
    offsets: np.ndarray
    channels: list[tuple[str, ...]] = field(default_factory=list)
    end_sites: dict[int, np.ndarray] = field(default_factory=dict)
    units: str = "m"
    up: str = "y"
    name: str = "skeleton"
    #: where each joint was declared (joint index -> line), and in which file, for errors; not compared
    lines: dict[int, int] = field(default_factory=dict, compare=False, repr=False)
    source: str = field(default="", compare=False, repr=False)

    def __post_init__(self):
        self.offsets = np.asarray(self.offsets, dtype=np.float64).reshape(-1, 3)
        n = len(self.names)
        if len(self.parents) != n or len(self.offsets) != n:
            raise DataError(f"skeleton {self.name}: {n} names, {len(self.parents)} parents, "
                            f"{len(self.offsets)} offsets")
        for j, p in enumerate(self.parents):
            if (j == 0) != (p < 0) or p >= j:
                raise DataError(f"skeleton {self.name}: joint {self.names[j]!r} has parent {p}; need depth-first order")
        if len(set(self.names)) != n:
            raise DataError(f"skeleton {self.name}: joint names are not unique")
        if not self.channels:
            self.channels = [ROOT_CHANNELS] + [JOINT_CHANNELS] * (n - 1)
        self.channels = [tuple(c) for c in self.channels]
        self.end_sites = {int(k): np.asarray(v, dtype=np.float64) for k, v in self.end_sites.items()}

    def __len__(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of a joint by name (a clear error when absent)."""
        try:
            return self.names.index(name)
        except ValueError:
            raise DataError(f"skeleton {self.name}: no joint named {name!r}") from None

    def where(self, j: int | None = None) -> str:
        """``file:LINE`` of joint ``j`` (or of the root) when the skeleton was read from a file, else its name."""
        if not self.source:
            return self.name
        line = self.lines.get(0 if j is None else j)
        return f"{self.source}:{line}" if line else self.source

    def children(self, j: int) -> list[int]:
        """Direct children of joint ``j``."""
        return [k for k, p in enumerate(self.parents) if p == j]

    def rest_positions(self) -> np.ndarray:
        """World joint positions ``(J, 3)`` in the rest pose."""
        pos = np.zeros((len(self), 3))
        for j, p in enumerate(self.parents):
            pos[j] = self.offsets[j] + (pos[p] if p >= 0 else 0.0)
        return pos

    def height(self) -> float:
        """Vertical extent of the rest pose (end sites included): the scale of position tolerances."""
        pos = self.rest_positions()
        pts = [pos] + [pos[j] + off for j, off in self.end_sites.items()]
        ys = np.concatenate([np.atleast_2d(p) for p in pts])[:, 1]
        return float(max(ys.max() - ys.min(), 1e-9))

    def mirror_pairs(self) -> list[int]:
        """For each joint, the index of its left/right counterpart (itself when unpaired)."""
        lookup = {n: j for j, n in enumerate(self.names)}
        return [next((lookup[c] for c in _swapped(name) if c in lookup), j) for j, name in enumerate(self.names)]

    def same_topology(self, other: Skeleton) -> bool:
        """True when joint names and parents agree (offsets may differ)."""
        return self.names == other.names and list(self.parents) == list(other.parents)

    def parent_names(self) -> dict[str, str | None]:
        """Each joint's parent by name (None for the root)."""
        return {n: (self.names[p] if p >= 0 else None) for n, p in zip(self.names, self.parents, strict=True)}

    def permutation_to(self, other: Skeleton) -> list[int] | None:
        """Indices into this skeleton that give ``other``'s joint order, when both have the same tree
        (names and parents by name); None otherwise."""
        if sorted(self.names) != sorted(other.names) or self.parent_names() != other.parent_names():
            return None
        return [self.names.index(n) for n in other.names]

    def scaled(self, factor: float, units: str | None = None) -> Skeleton:
        """A copy with offsets (and end sites) multiplied by ``factor``."""
        return Skeleton(list(self.names), list(self.parents), self.offsets * factor, list(self.channels),
                        {k: v * factor for k, v in self.end_sites.items()}, units or self.units, self.up, self.name,
                        dict(self.lines), self.source)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able description (stored in checkpoints)."""
        return {
            "name": self.name, "names": list(self.names), "parents": [int(p) for p in self.parents],
            "offsets": self.offsets.round(9).tolist(), "channels": [list(c) for c in self.channels],
            "end_sites": {str(k): v.round(9).tolist() for k, v in self.end_sites.items()},
            "units": self.units, "up": self.up,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Skeleton:
        """Inverse of :meth:`to_dict`."""
        try:
            return cls(list(data["names"]), list(data["parents"]), np.asarray(data["offsets"]),
                       [tuple(c) for c in data.get("channels", [])],
                       {int(k): np.asarray(v) for k, v in data.get("end_sites", {}).items()},
                       data.get("units", "m"), data.get("up", "y"), data.get("name", "skeleton"))
        except (KeyError, TypeError, ValueError) as exc:
            raise DataError(f"invalid skeleton description: {exc}") from None
