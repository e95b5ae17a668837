"""The glb checks' outside tools, skipped cleanly when absent: the Khronos glTF-Validator and three.js's
GLTFLoader (npm packages that ``make gltf-tools`` installs into ``.tools/node_modules``; another folder
through ``DANCE_NODE_MODULES``), the latter run in Debian's headless Chromium on a page served on loopback."""

from __future__ import annotations

import contextlib
import functools
import http.server
import json
import os
import shutil
import subprocess
import threading
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
MODULES = Path(os.environ.get("DANCE_NODE_MODULES", HERE.parents[2] / ".tools" / "node_modules"))
NODE = shutil.which("node")
BROWSER = next((shutil.which(n) for n in ("chromium", "chromium-browser") if shutil.which(n)), None)
needs_validator = pytest.mark.skipif(
    NODE is None or not (MODULES / "gltf-validator" / "package.json").is_file(),
    reason="needs node and the npm package gltf-validator (`make gltf-tools`)")
needs_three = pytest.mark.skipif(
    BROWSER is None or not (MODULES / "three" / "package.json").is_file(),
    reason="needs Chromium (`make browser`) and the npm package three (`make gltf-tools`)")


def validate(path: Path) -> dict:
    """The Khronos validator's counts (errors, warnings, infos, hints) and messages for a glTF file."""
    run = subprocess.run([NODE, str(HERE / "gltf" / "validate.js"), str(path)], capture_output=True, text=True,
                         timeout=120, check=False, env={**os.environ, "NODE_PATH": str(MODULES)})
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout)


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args) -> None:  # no request log on stderr
        pass


@contextlib.contextmanager
def served(folder: Path):
    """``folder`` with three.js beside it (``/three``, ``/jsm``), served on 127.0.0.1; yields the base URL."""
    (folder / "three").symlink_to(MODULES / "three" / "build")
    (folder / "jsm").symlink_to(MODULES / "three" / "examples" / "jsm")
    shutil.copy(HERE / "gltf" / "three_page.html", folder / "index.html")
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(_Quiet, directory=str(folder)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
