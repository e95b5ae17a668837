"""Core's default plugin: registers core's components through the public hooks (no torch here)."""

from __future__ import annotations

from pathlib import Path

from dance_core.components import configs as c
from dance_core.data import dataset_configs as dc
from dance_core.hookspecs import hookimpl
from dance_core.motion import configs as mc

_M = "dance_core.components"
RECIPES = Path(__file__).resolve().parent.parent / "recipes"


@hookimpl
def register_conditioners(register):
    """Core's per-frame MLP conditioner."""
    register("mlp", c.MLPConditionerConfig, f"{_M}.modules:build_mlp_conditioner",
             "per-frame MLP over one feature stream")


@hookimpl
def register_encoders(register):
    """Core's windowed MLP encoder."""
    register("window-mlp", c.WindowMLPConfig, f"{_M}.modules:build_window_mlp",
             "MLP over a flattened window of past motion and conditioning")


@hookimpl
def register_heads(register):
    """Core's deterministic regression head (AI Choreographer's head)."""
    register("regression", c.RegressionHeadConfig, f"{_M}.modules:build_regression_head",
             "deterministic frames with an L1 or L2 loss")


@hookimpl
def register_feature_extractors(register):
    """Core's dependency-free audio features."""
    register("energy", c.EnergyConfig, f"{_M}.energy:build",
             "log band energies and spectral-flux onset strength (numpy only)")


@hookimpl
def register_audio_readers(register):
    """Core's WAV reader."""
    register("wav", c.WavReaderConfig, f"{_M}.wav:build", "PCM and float WAV files",
             suffixes=(".wav", ".wave"))


@hookimpl
def register_motion_formats(register):
    """Core's lossless NPZ motion format."""
    register("npz", c.NpzFormatConfig, f"{_M}.npz:build", "frame array, fps and channel names",
             suffixes=(".npz",))
    register("bvh", mc.BvhFormatConfig, "dance_core.formats.bvh:build",
             "BVH mocap: any channel order, End Sites, continuous Euler", suffixes=(".bvh",))
    register("smpl", mc.SmplFormatConfig, "dance_core.formats.smpl:build",
             "AIST++ SMPL pickles (smpl_poses, smpl_trans), restricted unpickler", suffixes=(".pkl",))
    register("joints", mc.JointsFormatConfig, "dance_core.formats.joints:build",
             "HumanML3D new_joints arrays (T, 22, 3)", suffixes=(".npy",))
    register("keypoints", mc.KeypointsFormatConfig, "dance_core.formats.keypoints:build",
             "2D OpenPose BODY_25 keypoints as JSON (ours or DanceRevolution's dance_array)", suffixes=(".json",))
    for kind, what in (("gif", "animated GIF"), ("mp4", "MP4 video with the song"), ("html", "offline HTML player")):
        register(kind, mc.PreviewFormatConfig, "dance_core.render.preview:build",
                 f"stick-figure preview: {what} (write only)", suffixes=(f".{kind}",))


@hookimpl
def register_motion_representations(register):
    """Core's motion representations (skeletal motion to model features and back)."""
    register("rotations", mc.RotationRepresentationConfig, "dance_core.motion.representation:build_rotations",
             "root (Transflower's ground deltas or absolute) + joint rotations (expmap, 6d, quat, matrix)")
    register("positions", mc.PositionRepresentationConfig, "dance_core.motion.representation:build_positions",
             "root ground deltas + joint positions relative to the root (3D or 2D keypoints)")


@hookimpl
def register_datasets(register):
    """Core's synthetic beat-locked dataset."""
    register("synthetic-beats", c.SyntheticBeatsConfig, f"{_M}.synthetic:build",
             "click-track music with known beats and a beat-locked dancer")
    register("synthetic-dance", dc.SyntheticDanceConfig, "dance_core.data.synthetic_dance:build",
             "synthesized songs (drums, bass, chords) with a beat-locked SMPL dancer and move labels")
    register("folder", dc.FolderDatasetConfig, "dance_core.data.folders:build_folder",
             "a folder of name.<audio> + name.<motion> pairs (optional name.texts), cached features")
    register("aist", dc.AistDatasetConfig, "dance_core.data.folders:build_aist",
             "AIST++ layout: motions/*.pkl (SMPL, 60 fps), wav/, splits/; music id from the name")
    register("humanml3d", dc.HumanMLConfig, "dance_core.data.folders:build_humanml",
             "HumanML3D new_joints (T, 22, 3) at 20 fps with captions (no music)")


@hookimpl
def register_metrics(register):
    """Core's evaluation metrics (dance_core.evaluation), all on joint positions at any fps."""
    from dance_core.evaluation import configs as e

    m = "dance_core.evaluation.metrics"
    for name, config, build, text in (
        ("fid-k", e.FeatureMetricConfig, "build_fid_k", "FID_k: Fréchet distance of AIST++ kinetic features"),
        ("fid-g", e.FeatureMetricConfig, "build_fid_g", "FID_g: Fréchet distance of AIST++ geometric features"),
        ("div-k", e.FeatureMetricConfig, "build_div_k", "Div_k: mean pairwise distance of kinetic features"),
        ("div-g", e.FeatureMetricConfig, "build_div_g", "Div_g: mean pairwise distance of geometric features"),
        ("bas-bailando", e.BailandoBASConfig, "build_bas_bailando", "Bailando's Beat Align Score (over music beats)"),
        ("bas-fact", e.FactBASConfig, "build_bas_fact", "FACT's beat alignment score (over motion beats)"),
        ("freezing", e.FreezingConfig, "build_freezing", "TM2D's PFF and AUC_f (frozen frames)"),
        ("fpd", e.FrechetPoseConfig, "build_fpd", "Transflower's Fréchet pose distance"),
        ("fmd", e.FrechetPoseConfig, "build_fmd", "Transflower's Fréchet movement distance (3 frames)"),
        ("beat-offset", e.BeatOffsetConfig, "build_beat_offset", "Transflower's music-to-hips-beat offsets (s)"),
        ("beat-coverage", e.BeatCoverageConfig, "build_beat_coverage", "DanceRevolution's beat coverage and hit rate"),
        ("pfc", e.PFCConfig, "build_pfc", "EDGE's physical foot contact score"),
    ):
        register(name, config, f"{m}:{build}", text)


@hookimpl
def register_schedules(register):
    """Core's learning-rate schedules."""
    register("constant", c.ConstantConfig, f"{_M}.schedules:build_constant", "a constant value")
    register("cosine", c.CosineConfig, f"{_M}.schedules:build_cosine",
             "linear warm-up, then cosine decay to a floor")
    register("multistep", c.MultiStepConfig, f"{_M}.schedules:build_multistep",
             "warm-up, then multiply by gamma at each milestone")


@hookimpl
def register_recipes(register):
    """Core's bundled recipes."""
    register("core-synthetic", None, str(RECIPES / "core-synthetic.yaml"),
             "window-mlp + regression head on synthetic beats; trains on CPU in seconds")
    register("core-dance", None, str(RECIPES / "core-dance.yaml"),
             "window-mlp + regression head on the synthetic SMPL dancer; writes BVH")


@hookimpl
def register_commands(subparsers):
    """Core's commands that live outside the CLI's main module: ``dance evaluate``, ``dance render``."""
    from dance_core.cli import render
    from dance_core.cli.evaluate import add_parser

    add_parser(subparsers)
    render.add_parser(subparsers)
