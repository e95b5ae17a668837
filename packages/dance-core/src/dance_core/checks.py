"""Input checks every ``dance`` command (core's and plugins' ``register_commands``) runs on its arguments
before any heavy work; public (``dance_core.bounded_number``, ``check_input_file``...), so the CLI and
``dance_core``'s face import them from here.

Numbers are checked while parsing (:func:`bounded_number` as an argparse ``type=``), so a bad value is a
usage error naming its option; files and folders are checked by the command before it starts, each
failure one :class:`~dance_core.errors.DanceError` line naming the argument. No check leaves anything
behind: writability is probed with a temporary file that is removed at once, and an output folder is
not created here (the command creates it when it writes).
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from dance_core.atomic import special_file
from dance_core.errors import DanceError


def _fmt(value: float) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _range_text(low: float | None, high: float | None, above: bool, unit: str) -> str:
    unit = f" {unit}" if unit else ""
    if low is not None and high is not None:
        if above:
            return f"above {_fmt(low)} and at most {_fmt(high)}{unit}"
        return f"between {_fmt(low)} and {_fmt(high)}{unit}"
    if low is not None:
        return f"{'above' if above else 'at least'} {_fmt(low)}{unit}"
    return f"at most {_fmt(high)}{unit}" if high is not None else "a finite number"


def bounded_number(
    kind: type = float,
    low: float | None = None,
    high: float | None = None,
    *,
    above: bool = False,
    unit: str = "",
) -> Callable[[str], float]:
    """An argparse ``type=`` that parses an int or float and keeps it within physical limits.

    ``low``/``high`` are inclusive bounds (``above=True``: the value must be strictly above ``low``);
    NaN and infinities are refused. A bad value becomes ``argument --opt: must be ..., got X``.
    """
    expected = _range_text(low, high, above, unit)

    def parse(text: str) -> float:
        try:
            value = kind(text)
        except (TypeError, ValueError):
            word = "a whole number" if kind is int else "a number"
            raise argparse.ArgumentTypeError(f"expected {word}, got {text!r}") from None
        if isinstance(value, float) and not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"must be a finite number {expected}, got {text}")
        too_low = low is not None and (value <= low if above else value < low)
        if too_low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"must be {expected}, got {text}")
        return value

    parse.__name__ = kind.__name__  # what argparse names in its own messages
    return parse


def either(words: list[str]) -> str:
    """``a``, ``a or b``, ``a, b or c``."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} or {words[-1]}"


def _label(path: str | Path, option: str | None) -> str:
    return f"{option} {path}" if option else str(path)


def _article(what: str) -> str:
    return f"an {what}" if what[:1] in "aeiou" else f"a {what}"


def check_input_file(
    path: str | Path, option: str | None = None, what: str = "file", in_folder: str | None = None
) -> Path:
    """``path`` if it names a readable, non-empty regular file; else one line naming ``option`` and the path.

    ``in_folder``: a file name to suggest when a folder holding it is given instead (a run folder
    given as a checkpoint: ``did you mean RUN/model.safetensors?``).
    """
    p = Path(path)
    label = _label(path, option)
    if not p.exists():
        raise DanceError(f"{label}: {'broken link' if p.is_symlink() else what + ' not found'}")
    if p.is_dir():
        hint = ""
        if in_folder and (p / in_folder).is_file():
            hint = f" (did you mean {p / in_folder}?)"
        raise DanceError(f"{label}: is a folder, not {_article(what)}{hint}")
    if not p.is_file():
        raise DanceError(f"{label}: is not a regular file (a pipe or a device), not {_article(what)}")
    try:
        with open(p, "rb"):
            pass
    except OSError as exc:
        raise DanceError(f"{label}: cannot read {what} ({exc.strerror or exc})") from None
    if p.stat().st_size == 0:
        raise DanceError(f"{label}: {what} is empty")
    return p


def check_input_dir(path: str | Path, option: str | None = None, what: str = "folder") -> Path:
    """``path`` if it names an existing folder; else one line naming ``option`` and the path."""
    p = Path(path)
    label = _label(path, option)
    if not p.exists():
        raise DanceError(f"{label}: {what} not found")
    if not p.is_dir():
        raise DanceError(f"{label}: is a file, not {_article(what)}")
    return p


def _writable_ancestor(folder: Path, label: str) -> Path:
    """The nearest existing folder at or above ``folder``, after a probe proves it writable."""
    current = Path(os.path.abspath(folder))
    while not current.exists() and current.parent != current:
        current = current.parent
    if not current.is_dir():
        raise DanceError(f"{label}: {current} is a file, not a folder")
    try:
        fd, probe = tempfile.mkstemp(prefix=".dance-probe-", dir=current)
    except OSError as exc:
        raise DanceError(f"{label}: cannot write in {current} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)
    return current


def check_output_file(
    path: str | Path, option: str | None = None, suffixes: Iterable[str] | None = None
) -> Path:
    """``path`` if a file can be written there: not a folder, with an allowed suffix, under a folder that
    exists or can be created and is writable. Nothing is created."""
    p = Path(path)
    label = _label(path, option)
    if not str(path).strip():
        raise DanceError(f"{option or 'output'}: empty file name")
    allowed = [s.lower() for s in suffixes or ()]
    what = special_file(p)
    if what is not None:
        raise DanceError(f"{label}: is {what}, not a regular file; dance writes only regular files and never "
                         "replaces a link, device or pipe (name a new or regular file)")
    if p.is_dir():
        example = f" (e.g. {p / ('out' + allowed[0])})" if allowed else ""
        raise DanceError(f"{label}: is a folder; give a file name inside it{example}")
    if allowed and p.suffix.lower() not in allowed:
        raise DanceError(f"{label}: the file name must end in {either(allowed)}")
    _writable_ancestor(p.parent, label)
    return p


def check_output_dir(path: str | Path, option: str | None = None) -> Path:
    """``path`` if it is a writable folder, or can be created as one; nothing is created."""
    p = Path(path)
    label = _label(path, option)
    if not str(path).strip():
        raise DanceError(f"{option or 'output'}: empty folder name")
    what = special_file(p)
    if what is not None and not (what == "a symbolic link" and p.is_dir()):  # a link to a folder is a folder
        raise DanceError(f"{label}: is {what}, not a folder")
    if p.exists() and not p.is_dir():
        raise DanceError(f"{label}: is a file, not a folder")
    _writable_ancestor(p, label)
    return p


def refuse_same_names(paths: Iterable[str | Path], option: str | None = None, what: str = "song",
                      outputs: str = "dances") -> None:
    """One line, before any work, when two inputs would write outputs of the same name (``a/song.wav``
    and ``b/song.wav`` both give ``song.*``): one would silently replace the other."""
    seen: dict[str, str] = {}
    for path in paths:
        name = Path(path).stem
        if name in seen:
            raise DanceError(f"{_label(path, option)}: another {what} ({seen[name]}) has the same name; their "
                             f"{outputs} would overwrite each other (rename one)")
        seen[name] = str(path)


def available_memory() -> int | None:
    """Bytes of memory the machine can still give without swapping (Linux's ``MemAvailable``), or None
    where that is not known."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def refuse_beyond_memory(need: float, what: str, lower: str) -> None:
    """One line before any work when ``what`` needs about ``need`` bytes, more than the machine has free
    (``lower``: the options that ask for less)."""
    free = available_memory()
    if free is not None and need > free:
        raise DanceError(f"{what}: needs about {need / 2**30:.1f} GB of memory, more than the {free / 2**30:.1f} GB "
                         f"free; lower {lower}")


def nonfinite_reason(positions: Any, names: list[str] | None = None) -> str | None:
    """Where joint positions first hold NaN or inf (``"NaN at frame 12, joint 'Hips' (30 values)"``), or None."""
    import numpy as np

    bad = ~np.isfinite(np.asarray(positions, dtype=np.float64))
    if not bad.any():
        return None
    index = np.argwhere(bad)[0]
    frame = int(index[0])
    joint = ""
    if len(index) > 1:
        j = int(index[1])
        joint = f", joint {names[j]!r}" if names and j < len(names) else f", joint {j}"
    value = np.asarray(positions, dtype=np.float64)[tuple(index)]
    kind = "NaN" if np.isnan(value) else "inf"
    return f"{kind} at frame {frame}{joint} ({int(bad.sum())} non-finite values)"


def implausible_root(root: Any, fps: float, reach: float = 50.0, speed: float = 20.0) -> str | None:
    """Why a dance's root path ``(T, 3)`` in metres is not one a body could take (non-finite, farther than
    ``reach`` m from the origin, faster than ``speed`` m/s between two frames), or None when it could."""
    import numpy as np

    root = np.asarray(root, dtype=np.float64).reshape(-1, 3)
    reason = nonfinite_reason(root[:, None], ["root"])
    if reason is not None:
        return f"it holds {reason}"
    far = np.linalg.norm(root, axis=1)
    if len(far) and far.max() > reach:
        frame = int(np.argmax(far > reach))
        return f"its root is {far[frame]:.1f} m from the origin at frame {frame} (a dance stays within {reach:g} m)"
    fast = np.linalg.norm(np.diff(root, axis=0), axis=1) * fps
    if len(fast) and fast.max() > speed:
        frame = int(np.argmax(fast > speed))
        return (f"its root moves at {fast[frame]:.1f} m/s between frames {frame} and {frame + 1} "
                f"(a dancer stays under {speed:g} m/s)")
    return None
