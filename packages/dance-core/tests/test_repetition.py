"""A dance that loops is found, however it turns; one that keeps changing is not; short dances have no score."""

import numpy as np
from scipy.ndimage import gaussian_filter1d

from dance_core.evaluation.repetition import self_repetition
from dance_core.motion.skeletons import dance24

FPS = 20.0
REST = dance24().rest_positions()
NAMES = list(dance24().names)


def wandering(seconds: float, seed: int = 0, amplitude: float = 0.15) -> np.ndarray:
    """dance24's rest pose with every joint moving smoothly about it, never the same way twice (m)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FPS)
    moves = gaussian_filter1d(rng.normal(size=(n, len(REST), 3)), 3.0, axis=0)
    return REST[None] + moves * amplitude / moves.std()


def turned(positions: np.ndarray, angle: float) -> np.ndarray:
    """The positions turned by ``angle`` about the vertical through the root's first position."""
    c, s = np.cos(angle), np.sin(angle)
    p = positions - positions[:1, :1]
    out = p.copy()
    out[..., 0], out[..., 2] = c * p[..., 0] + s * p[..., 2], -s * p[..., 0] + c * p[..., 2]
    return out + positions[:1, :1]


def test_a_loop_scores_near_zero_even_when_each_cycle_turns():
    cycle = wandering(6.0, seed=1)
    loop = np.concatenate([turned(cycle, 0.4 * k) for k in range(10)])  # 60 s, each cycle 23 degrees round
    loop += np.random.default_rng(2).normal(scale=0.001, size=loop.shape)  # 1-mm jitter
    assert self_repetition(loop, FPS, NAMES) < 0.01
    # without the hips to turn by, the turning loop is not recognised: the turning is what hides it
    assert self_repetition(loop, FPS) > 0.03


def test_a_dance_that_keeps_changing_is_not_a_loop():
    assert self_repetition(wandering(60.0), FPS, NAMES) > 0.05


def test_short_dances_have_no_score_and_shorter_ones_a_smaller_window():
    assert np.isnan(self_repetition(wandering(2.0), FPS, NAMES))
    assert np.isfinite(self_repetition(wandering(12.0), FPS, NAMES))



def rotations(seconds: float, seed: int) -> np.ndarray:
    """Every joint of dance24 turning smoothly about its rest, never the same way twice (exponential maps)."""
    rng = np.random.default_rng(seed)
    rot = gaussian_filter1d(rng.normal(size=(int(seconds * FPS), len(REST), 3)), 3.0, axis=0)
    return 0.3 * rot / rot.std()


def test_dance_evaluate_names_the_dance_that_loops(tmp_path, capsys):
    import json

    from dance_core.cli.main import main
    from dance_core.formats.bvh import BvhFormat
    from dance_core.motion.motion import Motion
    from dance_core.motion.rotations import expmap_to_quat

    skel = dance24()
    (tmp_path / "gen").mkdir()
    for name, rot in (("looping", np.concatenate([rotations(6.0, 1)] * 8)), ("dancing", rotations(48.0, 2))):
        root = np.tile(skel.offsets[0], (len(rot), 1))
        BvhFormat().write_motion(Motion(skel, FPS, root, expmap_to_quat(rot)), tmp_path / "gen" / f"{name}.bvh")
    code = main(["-q", "evaluate", "--generated", str(tmp_path / "gen"), "--reference", str(tmp_path / "gen"),
                 "--metrics", "repetition", "--no-plots",
                 "-o", str(tmp_path / "r.json"), "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    result = report["metrics"]["repetition"]
    per = result["per_clip"]
    assert per["looping"]["repetition"] < 0.01 < 0.05 < per["dancing"]["repetition"]
    assert report["values"]["repetition_min"] == per["looping"]["repetition"]
    assert any("looping" in n and "a loop" in n for n in result["notes"])
    assert not any("dancing" in n for n in result["notes"])
