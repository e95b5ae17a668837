"""dance live's text commands without a model: the span syntax, the loopback TCP control, one line for bad input."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading

import pytest

from dance_core.errors import DataError
from dance_core.live.control import TcpControl, open_control
from dance_core.live.texts import MAX_COMMAND, NOW_SECONDS, parse_command


def test_spans_as_compose_reads_them_and_now_spans():
    span = parse_command("10-20: a person jumps", now=3.0)
    assert (span.text, span.start, span.end) == ("a person jumps", 10.0, 20.0)
    span = parse_command("  now: a person waves  ", now=3.2)
    assert (span.text, span.start, span.end) == ("a person waves", 3.2, 3.2 + NOW_SECONDS)
    assert parse_command("NOW+6.5: spin", now=1.0).end == 7.5


@pytest.mark.parametrize(("command", "why"), [
    ("a person jumps", "a span needs a start and an end"),
    ("5-: a person jumps", "a span needs a start and an end"),
    ("20-10: a person jumps", "must come after start"),
    ("1-2-3: x", "malformed span"),
    ("now:   ", "no text after the colon"),
    ("now+0: x", "lasts 0 < S <= 3600"),
    ("now: \x1b[31mred", "control characters"),
    ("now: " + "x" * MAX_COMMAND, f"longer than {MAX_COMMAND} characters"),
])
def test_a_bad_command_is_one_line(command, why):
    with pytest.raises(DataError, match=why) as err:
        parse_command(command, now=0.0)
    assert "\n" not in str(err.value) and str(err.value).startswith("text command ")


class _Handler:
    def __init__(self):
        self.lines, self.refused, self.done = [], [], threading.Event()

    def command(self, line, reply):
        self.lines.append(line)
        reply(f"ok: {line}")

    def refuse(self, message, reply):
        self.refused.append(message)
        reply(f"error: {message}")
        self.done.set()


def _talk(port: int, data: bytes) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=10) as conn:
        conn.sendall(data)
        conn.shutdown(socket.SHUT_WR)
        out = b""
        while chunk := conn.recv(4096):
            out += chunk
    return out


def test_the_tcp_control_answers_each_line_and_drops_a_client_sending_no_text():
    control, handler = open_control("tcp://127.0.0.1:0", audio_on_stdin=True), _Handler()
    try:
        control.start(handler)
        assert _talk(control.port, b"now: a person jumps\r\n\n4-6: spin\n") == \
            b"ok: now: a person jumps\nok: 4-6: spin\n"
        assert handler.lines == ["now: a person jumps", "4-6: spin"]
        reply = _talk(control.port, b"now: jump\n\xff\xfe\x00\nnow: never read\n")
        assert reply == (b"ok: now: jump\n"
                         b"error: control: a command that is not UTF-8 text; this control input is closed\n")
        reply = _talk(control.port, b"y" * (MAX_COMMAND + 10))
        assert reply.startswith(b"error: control: a command longer than") and reply.count(b"\n") == 1
        assert handler.lines[-1] == "now: jump" and len(handler.refused) == 2
    finally:
        control.shutdown()


def test_control_specs_that_cannot_be_are_one_line():
    with pytest.raises(DataError, match="standard input carries the audio"):
        open_control("-", audio_on_stdin=True)
    with pytest.raises(DataError, match="listens on the loopback interface only"):
        TcpControl("0.0.0.0", 0)
    with pytest.raises(DataError, match=r"expected - or tcp://127.0.0.1:PORT"):
        open_control("udp://127.0.0.1:9", audio_on_stdin=False)
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    try:
        with pytest.raises(DataError, match="cannot listen: the port is in use"):
            open_control(f"tcp://127.0.0.1:{taken.getsockname()[1]}", audio_on_stdin=False)
    finally:
        taken.close()


def test_text_for_a_model_that_reads_none_is_one_line_before_anything_opens():
    run = subprocess.run([sys.executable, "-m", "dance_core.cli.main", "live", "default", "--input", "-",
                          "--output", "-", "--text", "1-2: a person jumps"], capture_output=True, text=True,
                         timeout=120, input="")
    assert run.returncode == 1 and run.stdout == "" and run.stderr.count("\n") == 1
    assert "reads no text (no text stream in its features)" in run.stderr
