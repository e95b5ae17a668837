"""A small WebSocket server (RFC 6455, standard library only) that streams live frames to browsers, and
serves the live page over plain HTTP on the same port (``http://HOST:PORT/``).

Each client gets the skeleton first, then frames as text messages, through its own bounded queue: a
slow or stalled client loses frames (counted), never holds up the others or the model. A client that
closes, or a socket error, drops that client only.
"""

from __future__ import annotations

import base64
import contextlib
import hashlib
import json
import queue
import socket
import struct
import threading
from importlib import resources

from dance_core.live.sinks import QUEUE, Sink, frame_json, listen

GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"


def accept_key(key: str) -> str:
    """The ``Sec-WebSocket-Accept`` answer to a client's key."""
    return base64.b64encode(hashlib.sha1((key + GUID).encode()).digest()).decode()


def text_frame(text: str) -> bytes:
    """One unmasked, final text frame (what a server sends)."""
    data = text.encode()
    n = len(data)
    if n < 126:
        head = struct.pack(">BB", 0x81, n)
    elif n < 1 << 16:
        head = struct.pack(">BBH", 0x81, 126, n)
    else:
        head = struct.pack(">BBQ", 0x81, 127, n)
    return head + data


def live_page(title: str) -> bytes:
    """The live page, its title escaped (the only text put into it)."""
    import html

    page = resources.files("dance_core.live").joinpath("live.html").read_text(encoding="utf-8")
    return page.replace("__TITLE__", html.escape(title, quote=True)).encode()


class Client:
    """One connected browser: a queue and a writer thread."""

    def __init__(self, conn: socket.socket):
        self.conn, self.queue, self.dropped = conn, queue.Queue(QUEUE), 0
        self.alive = True

    def put(self, text: str) -> None:
        """Queue a message, or drop it when the client is behind."""
        try:
            self.queue.put_nowait(text)
        except queue.Full:
            self.dropped += 1

    def run(self) -> None:
        """Send queued messages until told to stop or the client goes."""
        try:
            while self.alive:
                text = self.queue.get()
                if text is None:
                    self.conn.sendall(struct.pack(">BB", 0x88, 0))  # close
                    return
                self.conn.sendall(text_frame(text))
        except OSError:
            pass
        finally:
            self.alive = False
            with contextlib.suppress(OSError):
                self.conn.close()


class WebSocketSink(Sink):
    """Frames to every WebSocket client of ``ws://host:port``; ``http://host:port/`` is the live page."""

    name = "ws"

    def __init__(self, host: str, port: int, title: str = "dance live"):
        super().__init__()
        self.host, self.port, self.title = host, port, title
        self.server = listen(host, port, f"--output ws://{host}:{port}")
        self.port = self.server.getsockname()[1]
        self.clients: list[Client] = []
        self.lock = threading.Lock()
        self.stopping = threading.Event()
        self.connected = 0

    @property
    def url(self) -> str:
        """The page's address."""
        return f"http://{self.host}:{self.port}/"

    def start(self, header: dict) -> None:  # noqa: D102 - no writer thread: one per client instead
        self.header = header
        threading.Thread(target=self._accept, name="live-ws", daemon=True).start()

    def send(self, frame: dict) -> None:  # noqa: D102
        text = frame_json(frame)
        with self.lock:
            self.clients = [c for c in self.clients if c.alive]
            for c in self.clients:
                c.put(text)
        self.sent += 1

    def close(self, timeout: float = 2.0) -> None:  # noqa: D102
        self.stopping.set()
        with self.lock:
            clients = list(self.clients)
        for c in clients:
            with contextlib.suppress(queue.Full):
                c.queue.put(None, timeout=timeout)
        self.shutdown()

    def shutdown(self) -> None:  # noqa: D102
        self.stopping.set()
        with contextlib.suppress(OSError):
            self.server.close()

    def stats(self) -> dict:  # noqa: D102
        with self.lock:
            dropped = self.dropped + sum(c.dropped for c in self.clients)
        return {"sent": self.sent, "dropped": dropped, "clients": self.connected, "url": self.url}

    def _accept(self) -> None:
        while not self.stopping.is_set():
            try:
                conn, _ = self.server.accept()
            except OSError:
                return
            threading.Thread(target=self._handshake, args=(conn,), name="live-ws-client", daemon=True).start()

    def _handshake(self, conn: socket.socket) -> None:
        try:
            conn.settimeout(5.0)
            request = b""
            while b"\r\n\r\n" not in request and len(request) < 16384:
                chunk = conn.recv(4096)
                if not chunk:
                    raise OSError("closed")
                request += chunk
            lines = request.split(b"\r\n\r\n")[0].decode("latin-1").split("\r\n")
            fields = {k.strip().lower(): v.strip() for k, _, v in (line.partition(":") for line in lines[1:])}
            key = fields.get("sec-websocket-key")
            if fields.get("upgrade", "").lower() != "websocket" or not key:
                self._http(conn, lines[0])
                return
            conn.sendall(("HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                          f"Sec-WebSocket-Accept: {accept_key(key)}\r\n\r\n").encode())
            conn.settimeout(None)
        except (OSError, UnicodeDecodeError):
            with contextlib.suppress(OSError):
                conn.close()
            return
        client = Client(conn)
        client.put(json.dumps(self.header, separators=(",", ":")))
        with self.lock:
            self.clients.append(client)
            self.connected += 1
        threading.Thread(target=client.run, name="live-ws-send", daemon=True).start()
        self._read(client)

    def _read(self, client: Client) -> None:
        """Read (and ignore) what the client sends, until it closes."""
        conn = client.conn
        try:
            while client.alive:
                head = conn.recv(2)
                if len(head) < 2 or head[0] & 0x0F == 0x8:  # gone, or a close frame
                    break
                n = head[1] & 0x7F
                if n == 126:
                    n = struct.unpack(">H", conn.recv(2))[0]
                elif n == 127:
                    n = struct.unpack(">Q", conn.recv(8))[0]
                left = n + (4 if head[1] & 0x80 else 0)
                while left > 0:
                    chunk = conn.recv(min(left, 65536))
                    if not chunk:
                        raise OSError("closed")
                    left -= len(chunk)
        except OSError:
            pass
        client.alive = False
        with contextlib.suppress(queue.Full):
            client.queue.put_nowait(None)

    def _http(self, conn: socket.socket, request_line: str) -> None:
        """Serve the live page for ``GET /``; anything else is 404."""
        try:
            method, path = (request_line.split(" ") + ["", ""])[:2]
            if method == "GET" and path in ("/", "/index.html"):
                body, status = live_page(self.title), "200 OK"
                kind = "text/html; charset=utf-8"
            else:
                body, status, kind = b"not found\n", "404 Not Found", "text/plain"
            conn.sendall(f"HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {len(body)}\r\n"
                         "Cache-Control: no-store\r\nConnection: close\r\n\r\n".encode() + body)
        finally:
            with contextlib.suppress(OSError):
                conn.close()
