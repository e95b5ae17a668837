"""The GLB container of glTF 2.0: a JSON document and one binary buffer, packed and unpacked.

:class:`BinaryBuilder` lays typed arrays into the buffer as accessors (each in its own 4-byte aligned
buffer view, with ``min``/``max`` when asked); :func:`pack_glb` and :func:`unpack_glb` write and read the
12-byte header and the JSON and BIN chunks; :func:`read_accessor` reads an accessor back, checking every
offset and count against the buffer first, so a hostile file is one error line, never an out-of-bounds read.
"""

from __future__ import annotations

import json
import struct
from typing import Any

import numpy as np

from dance_core.errors import DataError

MAGIC = b"glTF"
JSON_CHUNK = 0x4E4F534A
BIN_CHUNK = 0x004E4942
ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963
#: glTF component types: numpy dtype by code, and code by dtype
COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
CODES = {np.dtype(v): k for k, v in COMPONENTS.items()}
WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}


class BinaryBuilder:
    """Accumulates the binary buffer and the ``bufferViews``/``accessors`` that describe it."""

    def __init__(self):
        self.chunks: list[bytes] = []
        self.size = 0
        self.views: list[dict[str, Any]] = []
        self.accessors: list[dict[str, Any]] = []

    def add(self, array: np.ndarray, target: int | None = None, bounds: bool = False,
            kind: str | None = None) -> int:
        """Append ``array`` (``(count,)`` or ``(count, width)``; its dtype decides the component type)
        as one accessor in its own buffer view; ``kind`` overrides the type (``MAT4``). Its index."""
        array = np.ascontiguousarray(array)
        count = len(array)
        width = int(np.prod(array.shape[1:])) if array.ndim > 1 else 1
        data = array.astype(array.dtype.newbyteorder("<"), copy=False).tobytes()
        view: dict[str, Any] = {"buffer": 0, "byteOffset": self.size, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.views.append(view)
        pad = (-len(data)) % 4
        self.chunks.append(data + b"\0" * pad)
        self.size += len(data) + pad
        accessor: dict[str, Any] = {"bufferView": len(self.views) - 1, "componentType": CODES[array.dtype],
                                    "count": count, "type": kind or TYPES[width]}
        if bounds:
            flat = array.reshape(count, width)
            cast = float if array.dtype.kind == "f" else int
            accessor["min"] = [cast(v) for v in flat.min(axis=0)]
            accessor["max"] = [cast(v) for v in flat.max(axis=0)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1

    def buffer(self) -> bytes:
        """The binary buffer so far."""
        return b"".join(self.chunks)


def pack_glb(document: dict[str, Any], binary: bytes) -> bytes:
    """The GLB bytes of a glTF document and its buffer (JSON padded with spaces, BIN with zeros)."""
    text = json.dumps(document, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    text += b" " * ((-len(text)) % 4)
    binary += b"\0" * ((-len(binary)) % 4)
    chunks = struct.pack("<II", len(text), JSON_CHUNK) + text
    if binary:
        chunks += struct.pack("<II", len(binary), BIN_CHUNK) + binary
    return MAGIC + struct.pack("<II", 2, 12 + len(chunks)) + chunks


def unpack_glb(data: bytes, where: str) -> tuple[dict[str, Any], bytes]:
    """The JSON document and BIN chunk of GLB bytes; a one-line ``DataError`` naming ``where`` otherwise."""
    if len(data) < 20 or data[:4] != MAGIC:
        raise DataError(f"{where}: not a GLB file (no 'glTF' header)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise DataError(f"{where}: glTF version {version}; only glTF 2.0 is read")
    if length != len(data):
        raise DataError(f"{where}: GLB header says {length} bytes, the file has {len(data)} (truncated?)")
    document, binary, at = None, b"", 12
    while at + 8 <= length:
        size, kind = struct.unpack_from("<II", data, at)
        body = data[at + 8 : at + 8 + size]
        if len(body) != size:
            raise DataError(f"{where}: GLB chunk at byte {at} runs past the end of the file")
        if document is None:
            if kind != JSON_CHUNK:
                raise DataError(f"{where}: GLB's first chunk is not JSON")
            try:
                document = json.loads(body.decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise DataError(f"{where}: GLB JSON chunk: {exc}") from None
        elif kind == BIN_CHUNK and not binary:
            binary = body
        at += 8 + size
    if not isinstance(document, dict):
        raise DataError(f"{where}: GLB has no JSON object")
    return document, binary


def _item(document: dict[str, Any], key: str, index: Any, where: str) -> dict[str, Any]:
    items = document.get(key)
    if not isinstance(index, int) or isinstance(index, bool) or not isinstance(items, list) \
            or not 0 <= index < len(items) or not isinstance(items[index], dict):
        raise DataError(f"{where}: {key}[{index}] does not exist")
    return items[index]


def read_accessor(document: dict[str, Any], binary: bytes, index: Any, where: str) -> np.ndarray:
    """Accessor ``index`` as a float64 array ``(count, width)`` (normalized integers scaled to [-1, 1]
    or [0, 1]); bounds, types and strides checked against the GLB's binary chunk."""
    acc = _item(document, "accessors", index, where)
    at = f"{where}: accessors[{index}]"
    code, kind, count = acc.get("componentType"), acc.get("type"), acc.get("count")
    if code not in COMPONENTS or kind not in WIDTHS or not isinstance(count, int) or count < 0:
        raise DataError(f"{at}: componentType {code!r}, type {kind!r} or count {count!r} is not valid")
    if "sparse" in acc or "bufferView" not in acc:
        raise DataError(f"{at}: sparse or view-less accessors are not read")
    view = _item(document, "bufferViews", acc["bufferView"], where)
    if view.get("buffer", 0) != 0:
        raise DataError(f"{at}: only the GLB's own buffer (0) is read")
    dtype = np.dtype(COMPONENTS[code]).newbyteorder("<")
    width = WIDTHS[kind]
    item = dtype.itemsize * width
    stride = view.get("byteStride") or item
    start = int(view.get("byteOffset", 0)) + int(acc.get("byteOffset", 0))
    length = int(view.get("byteLength", 0))
    if not isinstance(stride, int) or stride < item or start < 0 or length < 0:
        raise DataError(f"{at}: byte stride or offsets are not valid")
    need = (count - 1) * stride + item if count else 0
    if start + need > int(view.get("byteOffset", 0)) + length or start + need > len(binary):
        raise DataError(f"{at}: {count} items run past the end of their buffer view or of the binary chunk")
    if count == 0:
        return np.zeros((0, width))
    raw = np.lib.stride_tricks.as_strided(np.frombuffer(binary, np.uint8, need, start), (count, item), (stride, 1))
    values = np.frombuffer(raw.copy().tobytes(), dtype).reshape(count, width).astype(np.float64)
    if acc.get("normalized") and dtype.kind in "iu":
        values = np.maximum(values / np.iinfo(dtype).max, -1.0)
    if not np.isfinite(values).all():
        raise DataError(f"{at}: holds values that are not finite")
    return values
