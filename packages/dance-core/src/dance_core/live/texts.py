"""Text spans while dancing live: ``--text`` spans given at the start and commands arriving meanwhile.

A span is ``START-END: TEXT`` in seconds of music, as ``dance compose --text`` reads it (an open end or no
span at all is refused live: the song's end is not known, and a model's weighting over a span needs its
length), or ``now: TEXT``: from the first frame not generated yet for :data:`NOW_SECONDS`
(``now+S: TEXT``: for ``S`` seconds). The spans' rows of the recipe's text streams are computed as
offline (the stream's extractors, the checkpoint's statistics); a bad command is one line, and the spans
already given stay.
"""

from __future__ import annotations

import re
import threading

import numpy as np
from pydantic import ValidationError

from dance_core.checkpoint import Checkpoint
from dance_core.data.features import FeatureStack
from dance_core.errors import DataError
from dance_core.media import TextSpan
from dance_core.recipe.schema import TextSpec
from dance_core.spans import SpanTable, TextSpans

#: seconds a ``now:`` span lasts (a weighting such as TM2D's late fusion needs the span's length)
NOW_SECONDS = 4.0
#: the longest command (characters) and the most spans a session keeps
MAX_COMMAND, MAX_SPANS = 500, 1000
_NOW = re.compile(r"^\s*now\s*(?:\+\s*(\d+(?:\.\d*)?)\s*)?:\s*(.*)$", re.I | re.S)


def parse_command(line: str, now: float) -> TextSpan:
    """A span from ``START-END: TEXT``, ``now: TEXT`` or ``now+S: TEXT`` (``now``: music seconds of the first
    frame a span can still change); :class:`DataError` with one line otherwise."""
    shown = line.strip()[:60] + ("..." if len(line.strip()) > 60 else "")
    if len(line) > MAX_COMMAND:
        raise DataError(f"text command {shown!r}: longer than {MAX_COMMAND} characters")
    if not line.isprintable():
        raise DataError(f"text command {shown!r}: control characters; expected START-END: TEXT or now: TEXT")
    match = _NOW.match(line)
    if match is not None:
        seconds, text = match.groups()
        length = float(seconds) if seconds else NOW_SECONDS
        if length <= 0 or length > 3600:
            raise DataError(f"text command {shown!r}: a now+S span lasts 0 < S <= 3600 seconds")
        start, end = now, now + length
    else:
        try:
            spec = TextSpec.parse(line)
        except ValidationError as exc:
            why = exc.errors()[0]["msg"].removeprefix("Value error, ")
            raise DataError(f"text command {shown!r}: {why}") from None
        except ValueError as exc:
            raise DataError(f"text command {shown!r}: {str(exc).splitlines()[0]}") from None
        if spec.start is None or spec.end is None:
            raise DataError(f"text command {shown!r}: live, a span needs a start and an end (START-END: TEXT, in "
                            f"seconds of music) or now: TEXT (the next {NOW_SECONDS:g} s)")
        start, end, text = spec.start, spec.end, spec.text
    text = text.strip()
    if not text:
        raise DataError(f"text command {shown!r}: no text after the colon")
    return TextSpan(text, float(start), float(end))


class LiveTexts:
    """The spans given so far and their rows of the recipe's text streams: ``add(span)``, ``spans()`` (a
    ``TextSpans`` for a song-level head), ``per_frame(stream, lo, hi)`` (a per-frame text stream's raw
    values, zeros where no span is in force, as offline). Thread-safe."""

    def __init__(self, stack: FeatureStack, checkpoint: Checkpoint, device=None):
        self.stack, self.stats, self.device = stack, checkpoint.stats, device
        self.fps = stack.fps
        self.streams = stack.text_streams()
        self.given: list[TextSpan] = []
        self.table = SpanTable.at((), 0, self.fps)  # raw rows
        self.lock = threading.Lock()

    def add(self, span: TextSpan) -> None:
        """One more span (its rows computed now; a word the vocabulary lacks is the extractor's one line)."""
        if len(self.given) >= MAX_SPANS:
            raise DataError(f"text: at most {MAX_SPANS} spans in a session")
        given = [*self.given, span]
        n = int(np.ceil(max(s.end for s in given) * self.fps)) + 1
        table = self.stack.span_table(n, tuple(given))
        with self.lock:
            self.given, self.table = given, table

    def spans(self) -> TextSpans | None:
        """The spans as a batch of one over the frames from the song's start (standardized rows), or None."""
        with self.lock:
            if not self.given:
                return None
            return TextSpans.stack([self.table.map_features(self.stats.apply_rows)], self.device)

    def per_frame(self, stream: str, lo: int, hi: int) -> np.ndarray:
        """Raw values ``(hi - lo, dim)`` of a text stream over frames ``[lo, hi)``."""
        with self.lock:
            table = self.table
        dim = sum(x.dim() for _, x in self.stack.streams[stream])
        out = np.zeros((hi - lo, dim), np.float32)
        if stream in table.features and lo < table.n_frames:
            part = table.per_frame(table.features[stream])[lo:hi]
            out[: len(part)] = part
        return out
