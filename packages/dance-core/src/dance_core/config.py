"""The base class of every component's pydantic configuration."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class ComponentConfig(BaseModel):
    """Options of one component; unknown options are errors, numbers like ``1e-4`` are numbers."""

    model_config = ConfigDict(extra="forbid", frozen=True)
