"""Entry module of the ``audio`` plugin: registers components lazily (no torch imported here)."""

from __future__ import annotations
