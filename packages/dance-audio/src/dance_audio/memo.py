"""A value computed once for the most recent audio, shared by the extractors that need it."""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import Any

from dance_core import Audio


class LastAudioMemo:
    """Remembers one value: the one computed for the last ``(audio, key)`` asked for.

    Thread-safe and computed once: an extractor asking while another computes the same value
    waits for it (a stack may run its extractors on several threads). The audio is compared by
    identity, so a new ``Audio`` object, even of the same file, is computed afresh.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._audio: Audio | None = None
        self._key: Hashable = None
        self._value: Any = None

    def get(self, audio: Audio, key: Hashable, compute: Callable[[], Any]) -> Any:
        """The value for ``(audio, key)``, from ``compute()`` unless it is the one remembered."""
        with self._lock:
            if self._audio is not audio or self._key != key:
                self._value = compute()
                self._audio, self._key = audio, key
            return self._value
