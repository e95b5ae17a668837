"""Commands while dancing live (``--control``): text spans typed on standard input or sent over a local TCP
socket, one per line (``now: a person jumps``, ``20-24: a person jumps``; :mod:`dance_core.live.texts`).

``--control -`` reads standard input (only when it does not carry the audio); ``--control tcp://127.0.0.1:PORT``
listens on the loopback interface alone (nothing else can send commands) and answers each line with one
line, ``ok: START-END: TEXT`` or ``error: ...``. A line longer than the longest command, bytes that are not
UTF-8 or a client that sends nothing useful get one line and are dropped; the dance goes on.
"""

from __future__ import annotations

import contextlib
import socket
import sys
import threading
from collections.abc import Callable
from typing import Protocol

from dance_core.errors import DataError
from dance_core.live.sinks import listen
from dance_core.live.texts import MAX_COMMAND

#: clients a control socket serves at once
MAX_CLIENTS = 4
LOOPBACK = ("127.0.0.1", "localhost", "::1")

Reply = Callable[[str], None] | None


class Handler(Protocol):
    """Where commands go: ``command(line, reply)``, and ``refuse(message, reply)`` for input that is no command."""

    def command(self, line: str, reply: Reply) -> None:
        """Act on one command line; answer through ``reply`` when the input has a way back."""
        ...

    def refuse(self, message: str, reply: Reply) -> None:
        """Report ``message`` (input that is no command) once, through ``reply`` or the session's notes."""
        ...


def _lines(read: Callable[[int], bytes], handler: Handler, reply: Reply) -> None:
    """Hand each line of a byte stream to ``handler`` until its end; input that is no text ends it."""
    while True:
        raw = read(MAX_COMMAND + 2)
        if not raw:
            return
        if not raw.endswith(b"\n") and len(raw) > MAX_COMMAND:
            handler.refuse(f"control: a command longer than {MAX_COMMAND} characters; this control input is closed",
                           reply)
            return
        try:
            line = raw.decode("utf-8").rstrip("\r\n")
        except UnicodeDecodeError:
            handler.refuse("control: a command that is not UTF-8 text; this control input is closed", reply)
            return
        if line.strip():
            handler.command(line, reply)


class StdinControl:
    """Commands on standard input."""

    name = "-"

    def start(self, handler: Handler) -> None:
        """Read standard input in a thread until it ends."""
        stream = sys.stdin.buffer
        threading.Thread(target=_lines, args=(stream.readline, handler, None), name="live-control",
                         daemon=True).start()

    def shutdown(self) -> None:
        """Nothing to close (standard input is the process's)."""


class TcpControl:
    """Commands over a TCP socket on the loopback interface."""

    def __init__(self, host: str, port: int):
        if host not in LOOPBACK:
            raise DataError(f"--control tcp://{host}:{port}: listens on the loopback interface only "
                            "(127.0.0.1, localhost or ::1)")
        family = socket.AF_INET6 if host == "::1" else socket.AF_INET
        self.server = listen(host, port, f"--control tcp://{host}:{port}", family, MAX_CLIENTS)
        self.host, self.port = host, self.server.getsockname()[1]
        self.name = f"tcp://{host}:{self.port}"
        self.clients = threading.Semaphore(MAX_CLIENTS)
        self.stopping = threading.Event()

    def start(self, handler: Handler) -> None:
        """Accept clients in a thread; each is read in its own."""
        threading.Thread(target=self._accept, args=(handler,), name="live-control", daemon=True).start()

    def shutdown(self) -> None:
        """Stop listening."""
        self.stopping.set()
        with contextlib.suppress(OSError):
            self.server.close()

    def _accept(self, handler: Handler) -> None:
        while not self.stopping.is_set():
            try:
                conn, _ = self.server.accept()
            except OSError:
                return
            if not self.clients.acquire(blocking=False):
                with contextlib.suppress(OSError):
                    conn.sendall(f"error: at most {MAX_CLIENTS} control clients at once\n".encode())
                conn.close()
                continue
            threading.Thread(target=self._serve, args=(conn, handler), name="live-control-client", daemon=True).start()

    def _serve(self, conn: socket.socket, handler: Handler) -> None:
        def reply(text: str) -> None:
            with contextlib.suppress(OSError):
                conn.sendall(text.encode("utf-8", "replace") + b"\n")

        try:
            with conn, conn.makefile("rb") as stream:
                _lines(stream.readline, handler, reply)
        except OSError:
            pass
        finally:
            self.clients.release()


def open_control(spec: str | None, audio_on_stdin: bool):
    """The ``--control`` source: ``-`` or ``tcp://HOST:PORT`` (loopback), opened now (a port in use is one
    line before the model loads); None without one."""
    from urllib.parse import urlsplit

    if spec is None:
        return None
    if spec == "-":
        if audio_on_stdin:
            raise DataError("--control -: standard input carries the audio (--input -); use --control "
                            "tcp://127.0.0.1:PORT")
        return StdinControl()
    parts = urlsplit(spec)
    try:
        port = parts.port
    except ValueError:
        port = None
    if parts.scheme != "tcp" or not parts.hostname or port is None:
        raise DataError(f"--control {spec}: expected - or tcp://127.0.0.1:PORT (a port 1-65535)")
    return TcpControl(parts.hostname, port)
