"""Pydantic configs of the motion representations (light: registering them imports no NumPy work)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from dance_core.config import ComponentConfig

RotationKind = Literal["expmap", "6d", "quat", "matrix"]


class RotationRepresentationConfig(ComponentConfig):
    """Joint rotations plus a root; Transflower's is ``rotation: expmap, root: deltas`` (67-d on 21 joints)."""

    rotation: RotationKind = "expmap"
    root: Literal["deltas", "absolute"] = "deltas"
    joints: list[str] | None = Field(None, description="joints to keep (others rest at identity); all when unset")


class PositionRepresentationConfig(ComponentConfig):
    """Joint positions relative to the root's ground point, plus root ground deltas and height."""

    dims: Literal[2, 3] = 3
    root: Literal["deltas", "absolute"] = "deltas"
