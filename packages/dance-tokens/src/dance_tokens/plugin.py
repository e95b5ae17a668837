"""Entry module of the ``tokens`` plugin: registers components lazily (no torch imported here)."""

from __future__ import annotations
