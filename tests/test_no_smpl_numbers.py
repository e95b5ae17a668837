"""Guard: no number derived from SMPL's body model (licensed non-commercial) is left in the repository.

SMPL's mean-shape template gave the old default skeleton its rest joint positions. This test holds
only SHA-256 prefixes of that template's joint triples (rest positions and parent-relative offsets,
metres, rounded to 4 decimals; x taken absolute so a mirrored joint counts), never the values
themselves, and looks for them among every three consecutive numbers of every tracked text file and
of the JSON header of every bundled safetensors file, in metres and in centimetres. A single triple
of 4-decimal numbers matching by chance is most unlikely; a file with several is the template or
something made from it.
"""

from __future__ import annotations

import hashlib
import json
import re
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SMPL_TRIPLE_HASHES = frozenset([
    "098daa0d2631", "0be579b235ec", "0e878ba5bbc1", "122b07a60c1b", "141375303579", "210834db4127", "265c5676a2fd",
    "2cf7d57dff26", "2ff7fce62929", "3026647eb30b", "307c0c1d5947", "33df64e7f831", "43b619070efa", "4409928e988d",
    "49019fcd4cfa", "4b251ca66c86", "4eab445b0761", "545b63b7555b", "555c8209dffc", "58239747fc17", "5c4b64498571",
    "603ac264d1fa", "6c789842ef9d", "7623bae43776", "7679d480dfaf", "7aa65cf5e8a7", "8349021db04a", "8a52f571de59",
    "9bdbebe23a4a", "9cc6707e519c", "9e601ba6fac1", "a0ad64678a32", "a9c28f58dddc", "be96cc39ebe7", "c15edfd8d1c6",
    "cd9e607c7d5e", "d5eab0ee514c", "dca4ebc672ac", "e76618460f60", "ebc4bd16bd22", "ec6c7ba39b73", "ed056a106c71",
    "eeaf0a952da8", "f428089e3f18", "f45c3a29bd0e", "f4a4be7eabbd", "fe9f9d00c70a",
])
#: a file with this many distinct template triples is flagged
LIMIT = 3
NUMBER = re.compile(r"-?\d+\.\d+(?:[eE][-+]?\d+)?")


def _key(x: float, y: float, z: float) -> str:
    r = [abs(round(x, 4)), round(y, 4), round(z, 4)]
    text = " ".join(f"{v:.4f}" for v in r).replace("-0.0000", "0.0000")
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def template_triples(text: str) -> set[str]:
    """The distinct SMPL template triples (as hashes) among consecutive decimal numbers of text,
    read in metres or in centimetres."""
    values = [float(t) for t in NUMBER.findall(text)]
    found = set()
    for i in range(len(values) - 2):
        x, y, z = values[i : i + 3]
        for k in (1.0, 0.01):
            h = _key(x * k, y * k, z * k)
            if h in SMPL_TRIPLE_HASHES:
                found.add(h)
    return found


def _tracked() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
        return [ROOT / p for p in out.decode().split("\0") if p]
    except (OSError, subprocess.CalledProcessError):
        return [p for p in ROOT.rglob("*") if p.is_file() and ".venv" not in p.parts and ".git" not in p.parts]


def _text(path: Path) -> str | None:
    data = path.read_bytes()
    if path.suffix == ".safetensors":
        (n,) = struct.unpack("<Q", data[:8])
        return json.dumps(json.loads(data[8 : 8 + n]).get("__metadata__", {}))
    if b"\0" in data[:4096]:
        return None
    return data.decode("utf-8", errors="replace")


def test_detector_is_exact_and_our_skeleton_passes():
    """The guard can fail: a triple is recognised whatever its sign of x, its unit or its printed
    precision, and our own skeleton's BVH and its rest positions hold no template triple."""
    from dance_core.formats.bvh import motion_to_bvh_text
    from dance_core.motion.motion import Motion
    from dance_core.motion.skeletons import dance24

    assert _key(-0.1234, 1.0, 2.0) == _key(0.1234, 1.0, 2.0) == _key(0.12341, 1.00004, 2.0)
    assert _key(0.1234, 1.0, 2.0) != _key(0.1234, 2.0, 1.0)
    assert len(SMPL_TRIPLE_HASHES) > 40
    skel = dance24()
    text = motion_to_bvh_text(Motion(skel, 30.0, skel.rest_positions()[:1], np.tile([0, 0, 0, 1.0], (1, 24, 1))))
    assert template_triples(text) == set()
    assert template_triples(" ".join(str(v) for v in skel.rest_positions().ravel())) == set()


@pytest.mark.parametrize("path", _tracked(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_smpl_template_numbers(path):
    if not path.is_file():
        pytest.skip("not in this checkout")
    text = _text(path)
    if text is None:
        return
    found = template_triples(text)
    assert len(found) < LIMIT, f"{path.relative_to(ROOT)} holds {len(found)} of SMPL's template joint triples"
