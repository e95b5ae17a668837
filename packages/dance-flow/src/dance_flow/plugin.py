"""Entry module of the ``flow`` plugin: registers components lazily (no torch imported here)."""

from __future__ import annotations
