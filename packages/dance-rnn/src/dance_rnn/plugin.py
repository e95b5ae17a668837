"""Entry module of the ``rnn`` plugin: registers components lazily (no torch imported here)."""

from __future__ import annotations
