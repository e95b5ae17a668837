"""Atomic file writes: temporary files beside their targets, renamed into place only on success.

Every temporary name is ``.TARGET.dance-PID-XXXXXXXX[SUFFIX]``: hidden, next to its target, carrying
the writing process's id. Ctrl-C, SIGTERM (raised as :class:`Terminated` while a write or an
:class:`OutputSet` is open) and errors remove it; one left by a killed process (SIGKILL, power loss)
is removed by :func:`sweep_stale_temps` the next time an output set writes that target.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import stat
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from types import TracebackType

from dance_core.errors import DataError

TEMP_MARK = ".dance-"


class Terminated(KeyboardInterrupt):
    """SIGTERM raised as an interrupt, so that ``finally`` blocks and context managers clean up."""


def _on_sigterm(signum, frame) -> None:
    raise Terminated("terminated (SIGTERM)")


def install_sigterm_handler() -> None:
    """Make SIGTERM raise :class:`Terminated` in this process from now on (main thread only)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _on_sigterm)


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """While the block runs, SIGTERM raises :class:`Terminated` instead of killing the process at once.

    Only in the main thread, and only where SIGTERM still has its default action: a handler the
    application installed itself (or ignoring SIGTERM) is left alone.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGTERM)
    if previous is not signal.SIG_DFL:
        yield
        return
    signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back while the block runs (delivered when it ends), where POSIX allows."""
    held = {signal.SIGINT, signal.SIGTERM}
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def output_mode() -> int:
    """The mode a new output file gets: ``0o666`` less the process's umask (0644 under umask 022)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


#: longest target name kept whole in its temporary name (file systems allow 255 bytes a name)
_TEMP_NAME_MAX = 160


def temp_stem(name: str) -> str:
    """The part of a temporary name standing for the target ``name``: the name itself, or for a name
    near the file-name length limit its head and a digest, so the temporary name still fits."""
    if len(name.encode("utf-8", "surrogateescape")) <= _TEMP_NAME_MAX:
        return name
    import hashlib

    digest = hashlib.sha256(name.encode("utf-8", "surrogateescape")).hexdigest()[:12]
    head = name.encode("utf-8", "surrogateescape")[:100].decode("utf-8", "ignore")
    return f"{head}~{digest}"


def _temp_file(path: Path, suffix: str | None) -> Path:
    suffix = suffix if suffix is not None else path.suffix
    if len(suffix) > 16:
        suffix = ""
    fd, tmp = tempfile.mkstemp(
        prefix=f".{temp_stem(path.name)}{TEMP_MARK}{os.getpid()}-",
        suffix=suffix,
        dir=path.parent,
    )
    os.close(fd)
    return Path(tmp)


def _publish(tmp: Path, path: Path, mode: int) -> None:
    # mkstemp creates 0600, and writers that replace the temporary file keep their own mode
    os.chmod(tmp, mode)
    os.replace(tmp, path)


_SPECIAL = ((stat.S_ISLNK, "a symbolic link"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
            (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))


def special_file(path: str | Path) -> str | None:
    """What ``path`` is when it is neither absent, a folder nor a regular file (``"a symbolic link"``,
    ``"a character device"``, ...), looked at without following a link; else None."""
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        return None
    return next((what for test, what in _SPECIAL if test(mode)), None)


def refuse_special(path: str | Path, label: str | None = None) -> None:
    """One line when ``path`` is a link, a device, a FIFO or a socket: dance writes only regular files,
    so it never replaces (or writes through) what it did not create."""
    what = special_file(path)
    if what is not None:
        raise DataError(f"{label or path}: is {what}, not a regular file; dance writes only regular files and "
                        "never replaces a link, device or pipe (name a new or regular file)")


def _check_target(path: Path) -> None:
    refuse_special(path)
    if path.is_dir():
        raise DataError(f"{path}: is a folder; cannot write a file there")


def pid_alive(pid: int) -> bool:
    """True when a process with this id exists (ours or another user's)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError:
        return False
    return True


def process_start(pid: int) -> str | None:
    """When process ``pid`` started (Linux: ``/proc/PID/stat``'s start time in clock ticks since boot, with the
    boot's id), or None where that cannot be read; with the pid it names one process, even once the pid is
    reused by another."""
    try:
        with open(f"/proc/{int(pid)}/stat", "rb") as fh:
            fields = fh.read().rsplit(b")", 1)[1].split()
        with open("/proc/sys/kernel/random/boot_id", encoding="ascii") as fh:
            boot = fh.read().strip()[:8]
        return f"{boot}:{int(fields[19])}"
    except (OSError, ValueError, IndexError):
        return None


def temp_owner(name: str, targets: Iterable[str] | None = None) -> int | None:
    """The pid in a temporary file's name (nested temporaries included), or None when ``name`` is
    not one of ours (or not one for ``targets``, when given)."""
    if not name.startswith("."):
        return None
    bare = name.lstrip(".")
    candidates = ([temp_stem(t).lstrip(".") for t in targets] if targets is not None
                  else [bare.split(TEMP_MARK, 1)[0]])
    for target in candidates:
        head = f"{target}{TEMP_MARK}"
        if target and bare.startswith(head):
            pid = bare[len(head) :].split("-", 1)[0]
            return int(pid) if pid.isdigit() else None
    return None


def target_of(path: str | Path) -> Path:
    """The file a temporary path of ours stands for (``.song.html.dance-PID-XXXX.html`` -> ``song.html``);
    any other path as it is. What a writer handed a temporary path names its output by."""
    path = Path(path)
    name = path.name
    if temp_owner(name) is None:
        return path
    return path.with_name(name[1:].split(TEMP_MARK, 1)[0])


def sweep_stale_temps(folder: str | Path, targets: Iterable[str] | None = None) -> list[Path]:
    """Remove the temporary files that dead processes left in ``folder`` (for ``targets`` only, when
    given); returns what was removed. Files of running processes are never touched."""
    removed = []
    targets = list(targets) if targets is not None else None
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        pid = temp_owner(entry.name, targets)
        if pid is None or pid_alive(pid) or not entry.is_file(follow_symlinks=False):
            continue
        with contextlib.suppress(FileNotFoundError):
            os.unlink(entry.path)
            removed.append(Path(entry.path))
    return removed


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; it replaces ``path`` (with the umask's mode) only if
    the block succeeds, and is removed otherwise, SIGTERM included."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _check_target(path)
    mode = output_mode()
    tmp: Path | None = None
    with sigterm_as_interrupt():
        try:
            tmp = _temp_file(path, suffix)
            yield tmp
            _publish(tmp, path, mode)
        finally:
            if tmp is not None:
                tmp.unlink(missing_ok=True)


class OutputSet:
    """Files that appear together or not at all.

    ``path(target)`` gives a temporary path beside ``target`` to write instead; when the ``with``
    block succeeds every temporary file is renamed onto its target in one pass, and when it fails
    (an error, Ctrl-C, SIGTERM) every one is removed, so no target is replaced. Stale temporary files
    of the same targets, left by a killed process, are swept away first.

    ``manifest``: a file that records the committed set (each file's name and size). It is removed
    before the first rename and written, atomically, after the last, so a set whose commit was cut
    short (a failed rename, a kill) has no manifest and :func:`set_complete` never takes it as whole.
    """

    def __init__(self, manifest: str | Path | None = None) -> None:
        self._pending: list[tuple[Path, Path]] = []
        self._stack = contextlib.ExitStack()
        self.manifest = Path(manifest) if manifest is not None else None

    def __enter__(self) -> OutputSet:
        self._stack.enter_context(sigterm_as_interrupt())
        return self

    def path(self, target: str | Path) -> Path:
        """A fresh temporary file (same suffix) standing for ``target`` until the set is committed."""
        target = Path(target)
        if any(t == target for _, t in self._pending):
            raise DataError(f"{target}: written twice in one output set")
        target.parent.mkdir(parents=True, exist_ok=True)
        _check_target(target)
        sweep_stale_temps(target.parent, [target.name])
        tmp = _temp_file(target, None)
        self._pending.append((tmp, target))
        return tmp

    def targets(self) -> list[Path]:
        """The targets asked for so far, in order."""
        return [t for _, t in self._pending]

    def commit(self) -> None:
        """Rename every temporary file onto its target (what a successful ``with`` block does)."""
        mode = output_mode()
        for tmp, target in self._pending:
            _check_target(target)
            if not tmp.exists():
                raise DataError(f"{target}: its writer left no file")
        record = None
        if self.manifest is not None:
            _check_target(self.manifest)
            record = json.dumps({"files": [{"name": t.name, "size": tmp.stat().st_size} for tmp, t in self._pending]},
                                sort_keys=True)
        with _signals_held():  # an interrupt lands after the rename pass, never inside it
            if self.manifest is not None:
                self.manifest.unlink(missing_ok=True)  # from here until the last rename the set is not whole
            for tmp, target in self._pending:
                _publish(tmp, target, mode)
            self._pending = []
            if self.manifest is not None and record is not None:
                write_text(self.manifest, record + "\n")

    def discard(self) -> None:
        """Remove every temporary file not yet committed."""
        for tmp, _ in self._pending:
            tmp.unlink(missing_ok=True)
        self._pending = []

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        try:
            if kind is None:
                self.commit()
        finally:
            self.discard()
            self._stack.close()


def set_complete(manifest: str | Path, targets: Iterable[str | Path]) -> bool:
    """True when ``manifest`` (written by a committed :class:`OutputSet`) lists exactly ``targets`` and
    each is a regular file of the recorded size: a set cut short, or a file replaced since, is not whole."""
    manifest = Path(manifest)
    if special_file(manifest) is not None or not manifest.is_file():
        return False
    try:
        files = json.loads(manifest.read_text(encoding="utf-8"))["files"]
        recorded = {str(f["name"]): int(f["size"]) for f in files}
    except (OSError, ValueError, KeyError, TypeError):
        return False
    targets = [Path(t) for t in targets]
    if sorted(recorded) != sorted(t.name for t in targets):
        return False
    for t in targets:
        if special_file(t) is not None or not t.is_file() or t.stat().st_size != recorded[t.name]:
            return False
    return True


def write_text(path: str | Path, text: str) -> None:
    """Write text atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write bytes atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
