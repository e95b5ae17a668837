"""dance live's inputs and outputs without a model: raw PCM, OSC/VMC encoding, the WebSocket server,
sinks that never block."""

from __future__ import annotations

import base64
import io
import json
import os
import socket
import struct
import threading
import urllib.request

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.live.osc import OscSink, bundle, message, parse
from dance_core.live.sinks import QUEUE, JsonLinesSink, open_sinks
from dance_core.live.sources import PcmSource
from dance_core.live.websocket import WebSocketSink, accept_key

HEADER = {"skeleton": {"name": "dance24", "joints": ["Pelvis", "L_Hip"], "parents": [-1, 0],
                       "offsets": [[0.0, 1.0, 0.0], [0.1, -0.1, 0.0]], "fps": 20.0}}


def _frame(i: int) -> dict:
    return {"t": i / 20, "frame": i, "root": [0.5, 1.0, -0.25], "rotations": [[0, 0, 0, 1], [0.1, 0.2, 0.3, 0.927]],
            "positions": [[0.5, 1.0, -0.25], [0.6, 0.9, -0.25]]}


def test_pcm_source_reads_s16le_in_any_chunking():
    samples = (np.sin(np.arange(3001) * 0.05) * 20000).astype("<i2")
    got = np.concatenate(list(PcmSource(io.BytesIO(samples.tobytes()), 22050).blocks()))
    assert np.allclose(got, samples / 32768.0)


def test_pcm_source_refuses_an_audio_file_and_a_stalled_stream():
    with pytest.raises(DataError, match="is a WAV file, not raw s16le"):
        list(PcmSource(io.BytesIO(b"RIFF\x24\x00\x00\x00WAVEfmt "), 22050).blocks())
    read, write = os.pipe()
    os.write(write, b"\x00\x01" * 100)
    try:
        with os.fdopen(read, "rb", buffering=0) as stream:
            source = PcmSource(stream, 22050, idle=0.3)
            blocks = source.blocks()
            assert len(next(blocks)) == 100
            with pytest.raises(DataError, match="no audio for 0.3 s; the stream stopped"):
                next(blocks)
    finally:
        os.close(write)


def test_osc_messages_and_bundles_round_trip():
    m = message("/VMC/Ext/Bone/Pos", "Hips", 1.5, -2.0, 0.25, 0.0, 0.0, 0.0, 1.0)
    assert len(m) % 4 == 0 and m.startswith(b"/VMC/Ext/Bone/Pos\0\0\0,sfffffff\0\0\0Hips\0\0\0\0")
    assert parse(m) == [("/VMC/Ext/Bone/Pos", ["Hips", 1.5, -2.0, 0.25, 0.0, 0.0, 0.0, 1.0])]
    b = bundle([m, message("/VMC/Ext/OK", 1)])
    assert b[:8] == b"#bundle\0" and struct.unpack(">Q", b[8:16])[0] == 1
    assert [a for a, _ in parse(b)] == ["/VMC/Ext/Bone/Pos", "/VMC/Ext/OK"] and parse(b)[1][1] == [1]


def test_osc_sink_sends_vmc_bones_in_unity_axes():
    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listener.bind(("127.0.0.1", 0))
    listener.settimeout(10)
    sink = OscSink("127.0.0.1", listener.getsockname()[1])
    sink.start(HEADER)
    sink.send(_frame(3))
    sink.close()
    msgs = dict((a + (":" + args[0] if args and isinstance(args[0], str) else ""), args)
                for a, args in parse(listener.recvfrom(65536)[0]))
    listener.close()
    hips, leg = msgs["/VMC/Ext/Bone/Pos:Hips"], msgs["/VMC/Ext/Bone/Pos:LeftUpperLeg"]
    assert np.allclose(hips[1:4], [-0.5, 1.0, -0.25])  # x mirrored
    assert np.allclose(leg[1:], [-0.1, -0.1, 0.0, 0.1, -0.2, -0.3, 0.927], atol=1e-6)
    assert msgs["/VMC/Ext/T"] == [pytest.approx(0.15)] and msgs["/VMC/Ext/OK"] == [1]


def _ws_connect(port: int) -> socket.socket:
    conn = socket.create_connection(("127.0.0.1", port), timeout=10)
    key = base64.b64encode(b"0123456789abcdef").decode()
    conn.sendall(f"GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                 f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n".encode())
    reply = b""
    while b"\r\n\r\n" not in reply:
        reply += conn.recv(1)
    assert b" 101 " in reply and accept_key(key).encode() in reply
    return conn


def _ws_message(conn: socket.socket) -> str | None:
    def exactly(n: int) -> bytes:
        data = b""
        while len(data) < n:
            chunk = conn.recv(n - len(data))
            assert chunk
            data += chunk
        return data

    b0, b1 = exactly(2)
    if b0 & 0x0F == 0x8:
        return None
    n = b1 & 0x7F
    n = struct.unpack(">H", exactly(2))[0] if n == 126 else struct.unpack(">Q", exactly(8))[0] if n == 127 else n
    return exactly(n).decode()


def test_websocket_clients_get_the_skeleton_then_frames_and_the_page_is_escaped():
    sink = WebSocketSink("127.0.0.1", 0, 'live <script>alert("x")</script>')
    sink.start(HEADER)
    page = urllib.request.urlopen(sink.url, timeout=10).read().decode()
    assert "&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;" in page and "<script>alert" not in page
    conn = _ws_connect(sink.port)
    assert json.loads(_ws_message(conn)) == HEADER
    while not sink.clients:  # the client is registered before its header is read
        threading.Event().wait(0.01)
    for i in range(3):
        sink.send(_frame(i))
    assert [json.loads(_ws_message(conn))["frame"] for _ in range(3)] == [0, 1, 2]
    sink.close()
    assert _ws_message(conn) is None  # a close frame at the end
    conn.close()
    assert sink.stats()["clients"] == 1


def test_a_port_in_use_and_bad_outputs_are_one_line():
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    port = taken.getsockname()[1]
    try:
        with pytest.raises(DataError, match=f"ws://127.0.0.1:{port}: cannot listen: the port is in use"):
            open_sinks([f"ws://127.0.0.1:{port}"])
    finally:
        taken.close()
    with pytest.raises(DataError, match="expected -, ws://HOST:PORT or osc://HOST:PORT"):
        open_sinks(["http://x:1"])
    with pytest.raises(DataError, match="needs a port"):
        open_sinks(["osc://127.0.0.1"])


class _Stalled(io.RawIOBase):
    """A consumer that never reads: every write waits until released."""

    def __init__(self):
        self.release = threading.Event()
        self.lines = []

    def write(self, data):
        self.release.wait()
        self.lines.append(bytes(data))
        return len(data)

    def flush(self):
        pass


def test_a_stalled_consumer_never_blocks_the_sender():
    stream = _Stalled()
    sink = JsonLinesSink(stream)
    sink.start(HEADER)
    for i in range(QUEUE + 50):  # returns at once although nothing is written
        sink.send(_frame(i))
    assert sink.dropped >= 49
    stream.release.set()
    sink.close()
    frames = [json.loads(line) for line in stream.lines[1:]]
    assert json.loads(stream.lines[0]) == HEADER
    assert len(frames) + sink.dropped == QUEUE + 50 and frames[0]["frame"] == 0
