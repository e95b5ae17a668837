import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dance_core.data.features import FeatureStack
from dance_core.data.prepare import dataset_sources, to_clip
from dance_core.errors import DataError
from dance_core.formats.smpl import SmplFormat
from dance_core.formats.wav import write_wav
from dance_core.recipe import load_recipe
from dance_core.registry import get_registry
from dance_core.synth.synthetic_dance import make_clip, write_dataset

sys.path.insert(0, str(Path(__file__).parent))
from smpl_model_helpers import smpl_model  # noqa: E402, F401 - fixture: a synthetic SMPL model in DANCE_SMPL_MODEL

TINY = ["training.steps=10", "training.batch_size=4", "training.val_every=10", "training.checkpoint_every=10",
        "data.mirror=false"]


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("pairs")
    write_dataset(out, songs=3, seed=4, seconds=6.0, fps=30.0, rate=8000)
    return out


def folder_recipe(path, *extra):
    return load_recipe("core-dance", [*TINY, f"data.dataset={{plugin: folder, path: {path}}}", *extra])


def prepared(recipe):
    stack = FeatureStack(recipe)
    return [to_clip(s, stack, get_registry()) for s in dataset_sources(recipe)]


def test_paired_folder_reads_motion_audio_and_texts(folder):
    recipe = folder_recipe(folder)
    sources = dataset_sources(recipe)
    assert [s.name for s in sources] == ["synth-0000", "synth-0001", "synth-0002"]
    first = make_clip(0, seed=4, seconds=6.0, bpm=(80.0, 140.0), rate=8000, fps=30.0)
    assert sources[0].texts[0].text == first.texts[0].text
    assert sources[0].motion.fps == 20.0 and sources[0].motion.values.shape == (120, 4 + 24 * 3)  # 30 -> 20 fps
    clips = prepared(recipe)
    assert len(clips[0]) == 120 and clips[0].streams["music"].shape[0] == 120


def test_feature_cache_is_keyed_by_content_and_extractor_config(folder, monkeypatch):
    calls = []
    original = FeatureStack.extract

    def counting(self, n, audio=None, texts=()):
        calls.append(audio.path)
        return original(self, n, audio, texts)

    monkeypatch.setattr(FeatureStack, "extract", counting)
    cache = folder / ".dance-cache"
    recipe = folder_recipe(folder)
    first = prepared(recipe)
    computed = len(calls)
    entries = len(list(cache.glob("*.npz")))
    assert entries >= 3
    again = prepared(recipe)  # a second epoch or run: nothing recomputed
    assert len(calls) == computed
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a.streams["music"], b.streams["music"])
    prepared(folder_recipe(folder, "features.music.0.n_fft=1024"))  # another extractor config
    assert len(calls) == computed + 3 and len(list(cache.glob("*.npz"))) == entries + 3
    wav = folder / "synth-0001.wav"
    data = bytearray(wav.read_bytes())
    data[-200:] = bytes(200)  # new content under the same name
    wav.write_bytes(bytes(data))
    prepared(recipe)
    assert len(calls) == computed + 4


def test_training_on_a_folder_dataset(folder, tmp_path):
    from dance_core.train import train

    result = train(folder_recipe(folder), out=str(tmp_path), quiet=True)
    assert np.isfinite(result.last_loss) and result.checkpoint.exists()


def test_folder_errors_name_the_file(tmp_path):
    make = make_clip(0, seed=1, seconds=3.0, bpm=(100.0, 100.0), rate=8000, fps=30.0)
    from dance_core.formats.bvh import BvhFormat

    BvhFormat().write_motion(make.motion.skeleton_motion, tmp_path / "lonely.bvh")
    with pytest.raises(DataError, match="lonely.bvh: no audio partner"):
        dataset_sources(folder_recipe(tmp_path))
    write_wav(tmp_path / "lonely.wav", np.zeros(8000 * 8, np.float32), 8000)  # 8 s of music, 3 s of dance
    with pytest.raises(DataError, match=r"lonely.wav: music lasts 8.00 s but its motion 3.00 s"):
        prepared(folder_recipe(tmp_path, "data.dataset.cache=null"))
    (tmp_path / "broken.bvh").write_text("HIERARCHY\nROOT x\n{\n")
    write_wav(tmp_path / "broken.wav", np.zeros(8000 * 3, np.float32), 8000)
    with pytest.raises(DataError, match="broken.bvh"):
        dataset_sources(folder_recipe(tmp_path))
    with pytest.raises(DataError, match="dataset folder not found"):
        dataset_sources(folder_recipe(tmp_path / "nope"))


@pytest.mark.usefixtures("smpl_model")
def test_aist_layout(tmp_path):
    seq = "gBR_sBM_cAll_d04_mBR0_ch01"
    clip = make_clip(0, seed=2, seconds=4.0, bpm=(100.0, 100.0), rate=8000, fps=60.0)
    (tmp_path / "motions").mkdir()
    (tmp_path / "wav").mkdir()
    (tmp_path / "splits").mkdir()
    SmplFormat().write_motion(clip.motion.skeleton_motion, tmp_path / "motions" / f"{seq}.pkl")
    write_wav(tmp_path / "wav" / "mBR0.wav", clip.audio.samples, clip.audio.rate)
    (tmp_path / "splits" / "crossmodal_train.txt").write_text(f"{seq}\n")
    recipe = load_recipe("core-dance", [*TINY, f"data.dataset={{plugin: aist, path: {tmp_path}}}"])
    sources = dataset_sources(recipe)
    assert sources[0].meta["music"] == "mBR0" and sources[0].audio_path.endswith("mBR0.wav")
    assert sources[0].motion.skeleton_motion.fps == 20.0 and sources[0].motion.values.shape[0] == 80
    read, written = sources[0].motion.skeleton_motion, clip.motion.skeleton_motion.resample(20.0)
    assert read.skeleton.names == written.skeleton.names  # read on the SMPL model's body: its rotations and root
    np.testing.assert_allclose(read.positions()[::5], replace(written, skeleton=read.skeleton).positions()[::5],
                               atol=2e-2)
    (tmp_path / "splits" / "crossmodal_train.txt").write_text(f"{seq}\ngBR_sBM_cAll_d04_mBR1_ch02\n")
    with pytest.raises(DataError, match="mBR1_ch02.pkl: motion listed in the split but missing"):
        dataset_sources(recipe)



@pytest.mark.usefixtures("smpl_model")
def test_aist_takes_the_smpl_model_from_the_recipe_or_says_what_it_needs(tmp_path, monkeypatch):
    import os

    from dance_core.formats.smpl_model import ENV_MODEL

    model = Path(os.environ[ENV_MODEL])  # the synthetic model, in tmp_path beside the recipe

    seq = "gBR_sBM_cAll_d04_mBR0_ch01"
    clip = make_clip(0, seed=2, seconds=2.0, bpm=(100.0, 100.0), rate=8000, fps=60.0)
    data = tmp_path / "aist"
    for sub in ("motions", "wav", "splits"):
        (data / sub).mkdir(parents=True)
    SmplFormat().write_motion(clip.motion.skeleton_motion, data / "motions" / f"{seq}.pkl")
    write_wav(data / "wav" / "mBR0.wav", clip.audio.samples, clip.audio.rate)
    (data / "splits" / "crossmodal_train.txt").write_text(f"{seq}\n")
    monkeypatch.delenv(ENV_MODEL)
    recipe = tmp_path / "aist.yaml"
    dataset = f"{{plugin: aist, path: aist, smpl_model: {model.name}}}"
    recipe.write_text(f"extends: core-dance\ndata:\n  dataset: {dataset}\n", encoding="utf-8")
    sources = dataset_sources(load_recipe(recipe))  # the model named in the recipe, relative to it
    assert sources[0].motion.skeleton_motion.skeleton.name == "smpl24"
    recipe.write_text("extends: core-dance\ndata:\n  dataset: {plugin: aist, path: aist}\n")
    with pytest.raises(DataError) as err:
        dataset_sources(load_recipe(recipe))
    assert "\n" not in str(err.value) and "--smpl-model" in str(err.value) and "motions" in str(err.value)


def test_humanml3d_layout(tmp_path):
    (tmp_path / "new_joints").mkdir()
    (tmp_path / "texts").mkdir()
    clip = make_clip(0, seed=3, seconds=3.0, bpm=(100.0, 100.0), rate=8000, fps=20.0)
    np.save(tmp_path / "new_joints" / "000007.npy", clip.motion.skeleton_motion.positions()[:, :22].astype(np.float32))
    (tmp_path / "texts" / "000007.txt").write_text(
        "a person jumps up and down.#a/DET person/NOUN#0.0#0.0\nthen waves#then/ADV#1.0#2.5\n")
    (tmp_path / "train.txt").write_text("000007\n")
    from dance_core.data.dataset_configs import HumanMLConfig
    from dance_core.data.folders import HumanMLDataset

    sources = HumanMLDataset(HumanMLConfig(path=str(tmp_path))).clips()
    assert sources[0].texts[0].text == "a person jumps up and down." and sources[0].texts[0].end is None
    assert (sources[0].texts[1].start, sources[0].texts[1].end) == (1.0, 2.5)
    assert sources[0].motion.values.shape == (60, 66) and sources[0].audio is None
    (tmp_path / "train.txt").write_text("000008\n")
    with pytest.raises(DataError, match="000008.npy"):
        HumanMLDataset(HumanMLConfig(path=str(tmp_path))).clips()
