"""OSC messages (Open Sound Control 1.0, our own encoder) and the VMC protocol's bone messages over UDP.

VMC (the Virtual Motion Capture protocol, read by VTuber and VR apps) sends, per frame, a bundle of
``/VMC/Ext/Root/Pos`` (the root's world position and rotation), one ``/VMC/Ext/Bone/Pos`` per Unity
humanoid bone (its local position and rotation), ``/VMC/Ext/T`` (time) and ``/VMC/Ext/OK``. Unity is
left-handed: positions are mirrored in x and quaternions ``(x, y, z, w)`` sent as ``(x, -y, -z, w)``.
dance24's joints map onto the humanoid bones by name (:data:`UNITY_BONES`); rotations are relative to
dance24's rest pose, a T-pose as Unity's humanoid rest.
"""

from __future__ import annotations

import contextlib
import socket
import struct

import numpy as np

from dance_core.errors import DataError
from dance_core.live.sinks import Sink

#: dance24 joint -> Unity HumanBodyBones name (the hands' end joints have no humanoid bone)
UNITY_BONES = {
    "Pelvis": "Hips", "L_Hip": "LeftUpperLeg", "R_Hip": "RightUpperLeg", "Spine1": "Spine",
    "L_Knee": "LeftLowerLeg", "R_Knee": "RightLowerLeg", "Spine2": "Chest", "L_Ankle": "LeftFoot",
    "R_Ankle": "RightFoot", "Spine3": "UpperChest", "L_Foot": "LeftToes", "R_Foot": "RightToes", "Neck": "Neck",
    "L_Collar": "LeftShoulder", "R_Collar": "RightShoulder", "Head": "Head", "L_Shoulder": "LeftUpperArm",
    "R_Shoulder": "RightUpperArm", "L_Elbow": "LeftLowerArm", "R_Elbow": "RightLowerArm", "L_Wrist": "LeftHand",
    "R_Wrist": "RightHand",
}


def _padded(data: bytes) -> bytes:
    """Null-terminated and padded to a multiple of 4 bytes, as OSC strings are."""
    return data + b"\0" * (4 - len(data) % 4)


def message(address: str, *args: str | float | int) -> bytes:
    """One OSC message: strings (``s``), 32-bit floats (``f``) and ints (``i``), big-endian."""
    tags, body = ",", b""
    for a in args:
        if isinstance(a, str):
            tags, body = tags + "s", body + _padded(a.encode())
        elif isinstance(a, (int, np.integer)) and not isinstance(a, bool):
            tags, body = tags + "i", body + struct.pack(">i", int(a))
        else:
            tags, body = tags + "f", body + struct.pack(">f", float(a))
    return _padded(address.encode()) + _padded(tags.encode()) + body


def bundle(messages: list[bytes]) -> bytes:
    """An OSC bundle of messages, to be applied at once (time tag 1: immediately)."""
    return b"#bundle\0" + struct.pack(">Q", 1) + b"".join(struct.pack(">i", len(m)) + m for m in messages)


def parse(packet: bytes) -> list[tuple[str, list]]:
    """The messages of an OSC packet (a message or a bundle) as ``(address, args)`` (for tests and tools)."""
    if packet.startswith(b"#bundle\0"):
        out, at = [], 16
        while at < len(packet):
            (size,) = struct.unpack(">i", packet[at : at + 4])
            out += parse(packet[at + 4 : at + 4 + size])
            at += 4 + size
        return out

    def string(at: int) -> tuple[str, int]:
        end = packet.index(b"\0", at)
        return packet[at:end].decode(), (end // 4 + 1) * 4

    address, at = string(0)
    tags, at = string(at)
    args: list = []
    for tag in tags[1:]:
        if tag == "s":
            value, at = string(at)
        else:
            value, at = struct.unpack(">f" if tag == "f" else ">i", packet[at : at + 4])[0], at + 4
        args.append(value)
    return [(address, args)]


def _unity(position, quaternion) -> list[float]:
    x, y, z = (float(v) for v in position)
    qx, qy, qz, qw = (float(v) for v in quaternion)
    return [-x, y, z, qx, -qy, -qz, qw]


class OscSink(Sink):
    """VMC bone messages over UDP to ``host:port`` (a VMC receiver listens on 39539)."""

    name = "osc"

    def __init__(self, host: str, port: int):
        super().__init__()
        try:
            self.address = socket.getaddrinfo(host, port, socket.AF_INET, socket.SOCK_DGRAM)[0][4]
        except OSError as exc:
            raise DataError(f"--output osc://{host}:{port}: cannot resolve {host}: {exc.strerror or exc}") from None
        self.socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.bones: list[tuple[int, str]] = []
        self.offsets: np.ndarray | None = None

    def begin(self, header: dict) -> None:  # noqa: D102
        joints = header["skeleton"]["joints"]
        self.bones = [(j, UNITY_BONES[n]) for j, n in enumerate(joints) if n in UNITY_BONES]
        if not self.bones:
            self.closed.set()  # nothing a VMC receiver knows; counted as closed
        self.offsets = np.asarray(header["skeleton"]["offsets"], np.float64)

    def write(self, frame: dict) -> None:  # noqa: D102
        rotations = frame.get("rotations")
        if rotations is None:
            return
        msgs = [message("/VMC/Ext/Root/Pos", "root", *_unity(frame["root"], rotations[0]))]
        for j, bone in self.bones:
            position = frame["root"] if j == 0 else self.offsets[j]
            msgs.append(message("/VMC/Ext/Bone/Pos", bone, *_unity(position, rotations[j])))
        msgs += [message("/VMC/Ext/T", float(frame["t"])), message("/VMC/Ext/OK", 1)]
        with contextlib.suppress(ConnectionRefusedError):  # nobody listens (yet): UDP carries on
            self.socket.sendto(bundle(msgs), self.address)

    def shutdown(self) -> None:  # noqa: D102
        self.socket.close()
