"""Core's evaluation: the papers' metrics on joint positions, and ``dance evaluate``."""

from __future__ import annotations

from dance_core.evaluation import configs as e
from dance_core.hookspecs import hookimpl

_M = "dance_core.evaluation.metrics"


@hookimpl
def register_metrics(register):
    """Core's evaluation metrics (dance_core.evaluation), all on joint positions at any fps."""
    for name, config, build, text in (
        ("fid-k", e.FeatureMetricConfig, "build_fid_k", "FID_k: Fréchet distance of AIST++ kinetic features"),
        ("fid-g", e.FeatureMetricConfig, "build_fid_g", "FID_g: Fréchet distance of AIST++ geometric features"),
        ("div-k", e.FeatureMetricConfig, "build_div_k", "Div_k: mean pairwise distance of kinetic features"),
        ("div-g", e.FeatureMetricConfig, "build_div_g", "Div_g: mean pairwise distance of geometric features"),
        ("bas-bailando", e.BailandoBASConfig, "build_bas_bailando", "Bailando's Beat Align Score (over music beats)"),
        ("bas-fact", e.FactBASConfig, "build_bas_fact", "FACT's beat alignment score (over motion beats)"),
        ("freezing", e.FreezingConfig, "build_freezing", "TM2D's PFF and AUC_f, and PFF relative to the reference"),
        ("fpd", e.FrechetPoseConfig, "build_fpd", "Transflower's Fréchet pose distance (heading-free)"),
        ("fmd", e.FrechetPoseConfig, "build_fmd", "Transflower's Fréchet movement distance (3 frames, heading-free)"),
        ("beat-offset", e.BeatOffsetConfig, "build_beat_offset", "Transflower's music-to-hips-beat offsets (s)"),
        ("beat-locking", e.BeatLockingConfig, "build_beat_locking", "Phase locking of kinematic to music beats"),
        ("beat-coverage", e.BeatCoverageConfig, "build_beat_coverage", "DanceRevolution's beat coverage and hit rate"),
        ("pfc", e.PFCConfig, "build_pfc", "EDGE's physical foot contact score"),
    ):
        register(name, config, f"{_M}:{build}", text)
    register(
        "sample-diversity",
        e.SampleDiversityConfig,
        "dance_core.evaluation.diversity:build_sample_diversity",
        "Mean pairwise distance between generated samples of the same song (SONG-k)",
    )
    register(
        "move-validity",
        e.MoveValidityConfig,
        "dance_core.evaluation.move_validity:build_move_validity",
        "Share of bars within a threshold of one of the synthetic dancer's move templates",
    )
    register(
        "realism",
        e.RealismConfig,
        "dance_core.evaluation.realism_metrics:build_realism",
        "Fréchet distance of window statistics (knee and elbow bend, steps, travel, turns...) to the reference",
    )
    register(
        "body-locking",
        e.BodyLockingConfig,
        "dance_core.evaluation.realism_metrics:build_body_locking",
        "Beat locking of the body's own accents (a rigid figure has none), with a wrong-tempo control",
    )
    register(
        "repetition",
        e.RepetitionConfig,
        "dance_core.evaluation.repetition:build_repetition",
        "Whether a dance has fallen into a loop: its last 40 s against itself 0.5-20 s earlier (m)",
    )
    register(
        "mpd",
        e.MPDConfig,
        "dance_core.evaluation.mpd:build_mpd",
        "TM2D's Motion Prediction Distance (m) to motion-matched futures of the reference dances",
    )


@hookimpl
def register_commands(subparsers):
    """``dance evaluate``: score a folder of dances."""
    from dance_core.cli.evaluate import add_parser

    add_parser(subparsers)
