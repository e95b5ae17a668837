"""Property-based fuzzing of every parser of untrusted input (issue 28): YAML recipes and ``--set``, BVH,
WAV headers, NPZ clips, safetensors headers and checkpoint metadata, text spans and the HTML preview's
embedding. The property is always the same: whatever the bytes, the parser returns a well-formed value
or raises its one-line error naming the input; nothing else escapes (no traceback, no NaN).

The budget is fixed and the examples derandomized, so CI runs the same cases in well under a minute:
``DANCE_FUZZ_EXAMPLES`` (default 40 per property) raises it for a release run, e.g.
``DANCE_FUZZ_EXAMPLES=5000 pytest packages/dance-core/tests/test_fuzz.py`` (docs/reliability.md).
"""

from __future__ import annotations

import io
import json
import os
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from dance_core.errors import CheckpointError, DanceError, DataError, RecipeError  # noqa: E402

EXAMPLES = int(os.environ.get("DANCE_FUZZ_EXAMPLES", "40"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=EXAMPLES <= 200, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                       HealthCheck.data_too_large])


def one_line(exc: BaseException, origin: str) -> None:
    message = str(exc)
    assert message.startswith(origin) and "\n" not in message, message


# ------------------------------------------------------------------------------------------------ recipes

scalars = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(allow_nan=True, allow_infinity=True),
                    st.text(max_size=20))
yaml_values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                            st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                           max_leaves=20)
yaml_words = st.sampled_from(["name:", "model:", "extends:", "&a", "*a", "[", "]", "{", "}", ",", "-", ":", "\n",
                              "  ", ".inf", ".nan", "1e999", "<<:", "!!str", "!!python/object", "'", '"', "#",
                              "9" * 30, "training:", "steps: 5", "? ", "|", ">", "%YAML 1.1", "---", "..."])


@FUZZ
@given(st.one_of(st.text(max_size=300), st.lists(yaml_words, max_size=60).map(" ".join)))
def test_any_text_parses_as_yaml_or_is_one_recipe_error(text):
    from dance_core.recipe.yaml_source import parse_text

    try:
        source = parse_text(text, "r.yaml")
    except RecipeError as exc:
        one_line(exc, "r.yaml")
        return
    json.dumps(source.data, default=str, allow_nan=True)  # the value is plain data, expandable without a bomb


@FUZZ
@given(yaml_values)
def test_any_recipe_document_validates_or_is_one_recipe_error(tmp_path_factory, data):
    import yaml

    from dance_core.recipe import load_recipe

    path = tmp_path_factory.mktemp("r") / "r.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    try:
        load_recipe(str(path))
    except RecipeError as exc:
        assert str(exc).startswith(str(path)) or str(path) in str(exc), exc


fields = st.sampled_from(["training.steps", "training.optimizer.lr", "seed", "data.dataset", "compose.samples",
                          "training.output", "model.head", "features", "nosuch.field", "training.stages.0"])


@FUZZ
@given(fields, st.one_of(st.text(max_size=40), st.lists(yaml_words, max_size=12).map(" ".join)))
def test_any_set_applies_or_is_one_dance_error(field, value):
    from dance_core.recipe import load_recipe

    try:
        recipe = load_recipe("core-synthetic", [f"{field}={value}"])
    except DanceError as exc:
        assert "\n" not in str(exc) or "--set" in str(exc), exc
        return
    json.dumps(recipe.model_dump(mode="json"), allow_nan=False)  # never a non-finite number in a valid recipe


# ---------------------------------------------------------------------------------------------------- BVH


def _bvh_text() -> str:
    from test_reliability import BVH

    return BVH


bvh_edits = st.lists(st.tuples(st.integers(0, 10_000), st.sampled_from(
    ["", "nan", "inf", "-1", "1e999", "0", "999999999999", "{", "}", "JOINT", "End Site", "CHANNELS", "OFFSET",
     "Frames:", "Frame Time:", "\n", "\t", "x", "3", "\ufeff", "ROOT", "MOTION", "Xrotation", "1e5"])),
    max_size=6)


@FUZZ
@given(bvh_edits)
def test_any_edited_bvh_reads_finite_or_is_one_line_naming_the_file(tmp_path_factory, edits):
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from dance_core.formats.bvh import BvhFormat

    words = _bvh_text().split(" ")
    for at, word in edits:
        words[at % len(words)] = word
    path = tmp_path_factory.mktemp("b") / "d.bvh"
    path.write_text(" ".join(words), encoding="utf-8")
    try:
        data = BvhFormat().read(path)
    except DataError as exc:
        one_line(exc, str(path))
        return
    assert data.values.ndim == 2 and np.isfinite(data.values).all() and data.fps > 0


# ---------------------------------------------------------------------------------------------------- WAV

u16, u32 = st.integers(0, 0xFFFF), st.integers(0, 0xFFFFFFFF)


@FUZZ
@given(u16, u16, u32, u16, st.binary(max_size=400), st.sampled_from([None, 0, 1, 7, 0xFFFFFFFF]))
def test_any_wav_header_reads_or_is_one_line_naming_the_file(tmp_path_factory, fmt, channels, rate, bits, data,
                                                              declared):
    from dance_core.data.features import load_audio
    from dance_core.formats.wav import WavReader
    from dance_core.registry import get_registry

    block = (channels * bits // 8) & 0xFFFF
    head = struct.pack("<IHHIIHH", 16, fmt, channels, rate, (rate * block) & 0xFFFFFFFF, block, bits)
    size = len(data) if declared is None else declared
    content = b"RIFF" + struct.pack("<I", 36 + len(data)) + b"WAVE" + b"fmt " + head + b"data" + \
        struct.pack("<I", size) + data
    path = tmp_path_factory.mktemp("w") / "s.wav"
    path.write_bytes(content)
    for read in (lambda: WavReader().read(path), lambda: load_audio(path, get_registry())):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                audio = read()
        except DanceError as exc:
            one_line(exc, str(path))
            continue
        assert audio.rate >= 1 and np.isfinite(audio.samples).all()


# ---------------------------------------------------------------------------------------------------- NPZ

dtypes = st.sampled_from(["f4", "f8", "f2", "i4", "u1", "c8", "c16", "?", "U3", "S2", "M8[s]", "O"])


@FUZZ
@given(dtypes, st.lists(st.integers(0, 5), max_size=3), dtypes, st.lists(st.integers(0, 3), max_size=2),
       st.booleans(), st.integers(0, 8))
def test_any_npz_reads_as_motion_or_is_one_line_naming_the_file(tmp_path_factory, vtype, vshape, ftype, fshape,
                                                                 channels, n_channels):
    from dance_core.formats.npz import NpzFormat

    arrays = {}
    for key, kind, shape in (("values", vtype, vshape), ("fps", ftype, fshape)):
        try:
            arrays[key] = np.ones(shape, dtype=kind) if kind != "O" else np.array([{"a": 1}], dtype=object)
        except (TypeError, ValueError):
            arrays[key] = np.zeros(shape)
    if channels:
        arrays["channels"] = np.array([f"c{k}" for k in range(n_channels)])
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    path = tmp_path_factory.mktemp("n") / "c.npz"
    path.write_bytes(buf.getvalue())
    try:
        motion = NpzFormat().read(path)
    except DataError as exc:
        one_line(exc, str(path))
        return
    assert motion.values.ndim == 2 and motion.values.dtype == np.float32 and np.isfinite(motion.fps)
    assert motion.fps > 0 and (motion.channels is None or len(motion.channels) == motion.values.shape[1])


# ----------------------------------------------------------------------------- safetensors and checkpoints

json_values = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(),
                                     st.floats(allow_nan=False, allow_infinity=False),
                                     st.text(max_size=10)),
                           lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                   st.dictionaries(st.text(max_size=6), inner, max_size=3)),
                           max_leaves=10)


@FUZZ
@given(st.one_of(json_values.map(lambda v: json.dumps(v).encode()), st.binary(max_size=200)),
       st.one_of(st.none(), st.integers(0, 2**64 - 1)), st.binary(max_size=64))
def test_any_safetensors_header_is_a_checkpoint_or_one_line(tmp_path_factory, header, declared, tail):
    from dance_core.checkpoint import load_checkpoint, train_state_info

    size = len(header) if declared is None else declared
    path = tmp_path_factory.mktemp("c") / "model.safetensors"
    path.write_bytes(struct.pack("<Q", size) + header + tail)
    for load in (load_checkpoint, train_state_info):
        try:
            load(path)
        except CheckpointError as exc:
            one_line(exc, str(path))


meta_values = st.one_of(json_values.map(json.dumps), st.text(max_size=20))


@FUZZ
@given(st.fixed_dictionaries({}, optional={"recipe": meta_values, "motion": meta_values, "versions": meta_values,
                                           "step": meta_values, "run": st.text(max_size=8)}))
def test_any_checkpoint_metadata_loads_or_is_one_line(tmp_path_factory, meta):
    import torch

    from dance_core.checkpoint import FORMAT, load_checkpoint, write_safetensors

    path = tmp_path_factory.mktemp("m") / "model.safetensors"
    write_safetensors(path, {"model.w": torch.zeros(2)}, {"format": FORMAT, **meta})
    try:
        ckpt = load_checkpoint(path)
    except CheckpointError as exc:
        one_line(exc, str(path))
        return
    assert isinstance(ckpt.recipe, dict) and isinstance(ckpt.versions, dict) and ckpt.step >= 0


# ------------------------------------------------------------------------------------------------ text spans

span_words = st.sampled_from(["-", ":", "1", "20", "3.5", ".", " ", "e", "+", "jump", "a person", "nan", "inf"])


@FUZZ
@given(st.one_of(st.text(max_size=30), st.lists(span_words, max_size=10).map("".join)))
def test_any_text_is_a_span_or_an_error_never_a_bad_span(given_text):
    from dance_core.recipe.schema import TextSpec

    try:
        spec = TextSpec.parse(given_text)
    except ValueError as exc:
        assert "\n" not in str(exc).split("\n")[0]
        return
    assert spec.text and spec.text == spec.text.strip()
    assert spec.start is None or (np.isfinite(spec.start) and spec.start >= 0)
    assert spec.end is None or (np.isfinite(spec.end) and spec.end > (spec.start or 0))


# --------------------------------------------------------------------------------------------- HTML preview


@FUZZ
@given(st.text(max_size=60), st.lists(st.text(max_size=12), min_size=3, max_size=3))
def test_any_title_and_joint_names_round_trip_through_the_preview_unharmed(title, names):
    from test_untrusted import PARENTS, _positions, _script_data

    from dance_core.render.html import player_html

    page = player_html(_positions(), PARENTS, names, 30.0, title=title)
    data = _script_data(page)
    assert data["title"] == title and data["names"] == names
    assert page.count("<script") == 2 and page.count("</script>") == 2


@FUZZ
@given(json_values)
def test_script_json_is_always_inert_and_exact(value):
    from dance_core.render.html import script_json

    blob = script_json(value)
    assert json.loads(blob) == value and not set(blob) & set("<>&\u2028\u2029")
