"""Where live frames go. Each sink writes from its own thread through a bounded queue, so a slow
consumer never holds up the audio or the model: when its queue is full the frame is dropped for that
sink and counted. ``open_sinks`` parses the ``--output`` specs and opens every sink (ports bound,
hosts resolved) before any heavy work."""

from __future__ import annotations

import contextlib
import json
import queue
import socket
import sys
import threading
from typing import Any, BinaryIO

from dance_core.errors import DataError

#: frames a sink may hold before it drops (5 s at 20 fps)
QUEUE = 100


class Sink:
    """A consumer of frames: ``start(header)``, ``send(frame)`` (never blocks), ``close()``."""

    name = "sink"

    def __init__(self) -> None:
        self.queue: queue.Queue = queue.Queue(QUEUE)
        self.dropped = 0
        self.sent = 0
        self.closed = threading.Event()  # the consumer went away
        self.thread: threading.Thread | None = None
        self.header: dict | None = None

    def start(self, header: dict) -> None:
        """Begin with the skeleton description (sent first, never dropped)."""
        self.header = header
        self.thread = threading.Thread(target=self._run, name=f"live-{self.name}", daemon=True)
        self.thread.start()

    def send(self, frame: dict) -> None:
        """Queue a frame; drop it (counted) when the sink is behind."""
        if self.closed.is_set():
            return
        try:
            self.queue.put_nowait(frame)
        except queue.Full:
            self.dropped += 1

    def close(self, timeout: float = 5.0) -> None:
        """Write what is queued (up to ``timeout`` seconds), then stop."""
        if self.thread is not None:
            with contextlib.suppress(queue.Full):
                self.queue.put(None, timeout=timeout)
            self.thread.join(timeout)
        self.shutdown()

    def _run(self) -> None:
        try:
            self.begin(self.header)
            while True:
                frame = self.queue.get()
                if frame is None or self.closed.is_set():
                    return
                self.write(frame)
                self.sent += 1
        except (BrokenPipeError, ConnectionError, OSError, ValueError):
            self.closed.set()

    def begin(self, header: dict) -> None:
        """Write the header (in the sink's thread)."""

    def write(self, frame: dict) -> None:
        """Write one frame (in the sink's thread)."""
        raise NotImplementedError

    def shutdown(self) -> None:
        """Release what the sink holds."""

    def stats(self) -> dict[str, Any]:
        """Frames written and dropped."""
        return {"sent": self.sent, "dropped": self.dropped, "closed_by_consumer": self.closed.is_set()}


def frame_json(frame: dict) -> str:
    """One frame as a compact JSON line (5 decimals: 10 µm)."""
    return json.dumps(frame, separators=(",", ":"))


class JsonLinesSink(Sink):
    """JSON Lines on a binary stream (standard output): the skeleton, then one object per frame."""

    name = "stdout"

    def __init__(self, stream: BinaryIO | None = None):
        super().__init__()
        self.stream = stream if stream is not None else sys.stdout.buffer

    def begin(self, header: dict) -> None:  # noqa: D102
        self._line(json.dumps(header, separators=(",", ":")))

    def write(self, frame: dict) -> None:  # noqa: D102
        self._line(frame_json(frame))

    def _line(self, text: str) -> None:
        self.stream.write(text.encode() + b"\n")
        self.stream.flush()


def listen(host: str, port: int, where: str, family: int = socket.AF_INET, backlog: int = 8) -> socket.socket:
    """A TCP socket listening on ``host:port``; one line naming ``where`` (the option) when it cannot."""
    server = socket.socket(family, socket.SOCK_STREAM)
    try:
        server.bind((host, port))
    except OSError as exc:
        server.close()
        why = "the port is in use" if exc.errno in (98, 48, 10048) else (exc.strerror or str(exc))
        raise DataError(f"{where}: cannot listen: {why}") from None
    server.listen(backlog)
    return server


def open_sinks(specs: list[str], page_title: str = "dance live") -> list[Sink]:
    """The sinks named by ``--output``: ``-`` (JSON Lines on standard output), ``ws://HOST:PORT`` (a
    WebSocket server, which also serves the live page over HTTP), ``osc://HOST:PORT`` (VMC over OSC);
    each opened now, so a port in use or an unknown host is one line before the model loads."""
    from urllib.parse import urlsplit

    sinks: list[Sink] = []
    try:
        for spec in specs:
            if spec == "-":
                if any(isinstance(s, JsonLinesSink) for s in sinks):
                    raise DataError("--output -: given twice")
                sinks.append(JsonLinesSink())
                continue
            parts = urlsplit(spec)
            if parts.scheme not in ("ws", "osc") or not parts.hostname:
                raise DataError(f"--output {spec}: expected -, ws://HOST:PORT or osc://HOST:PORT")
            try:
                port = parts.port
            except ValueError:
                port = None
            if port is None:
                raise DataError(f"--output {spec}: needs a port 1-65535 (ws://127.0.0.1:8765, osc://127.0.0.1:39539)")
            if parts.scheme == "ws":
                from dance_core.live.websocket import WebSocketSink

                sinks.append(WebSocketSink(parts.hostname, port, page_title))
            else:
                from dance_core.live.osc import OscSink

                sinks.append(OscSink(parts.hostname, port))
    except BaseException:
        for sink in sinks:
            sink.shutdown()
        raise
    return sinks
