"""Diversity across samples of the same song: does a model dance one song more than one way?

Bailando's Div_k / Div_g (:class:`dance_core.evaluation.metrics.FeatureDiversity`) pool every
generated clip, so a model that dances every song its own single way still scores high: the songs
differ. Here generated clips are grouped by song (a file ``SONG-k`` is sample ``k`` of ``SONG``,
:func:`dance_core.evaluation.music.song_stem`) and only samples of one song are compared:

- ``Div_sample_pose`` (m): the root-mean-square distance between the samples' joints at the same
  time of the song, with each frame in its own body frame (root over the origin, hips facing +Z,
  :func:`dance_core.evaluation.metrics.pose_windows`), so two samples that dance the same moves
  facing different ways or at different spots are the same dance. Samples are cut to the
  shortest one of their song.
- ``Div_sample_k``: the Euclidean distance between the samples' kinetic features, normalized by
  the reference set's statistics like Div_k (or by the generated set's own, with a note).

Each is the mean over pairs within a song, then over songs with at least two samples
(``sample_songs`` counts them).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dance_core.evaluation.clips import require_clips
from dance_core.evaluation.frechet import average_pairwise_distance
from dance_core.evaluation.metrics import normalized_features, pose_windows
from dance_core.evaluation.music import song_stem
from dance_core.protocols import JointClip, MetricResult

WHAT = "sample diversity"


def songs_of(clips: Sequence[JointClip]) -> dict[str, list[int]]:
    """Indices of the clips by song: ``SONG-k`` belongs to ``SONG``, any other name to itself."""
    groups: dict[str, list[int]] = {}
    for i, clip in enumerate(clips):
        groups.setdefault(song_stem(clip.name)[-1], []).append(i)
    return groups


def pose_distance_rows(frames: Sequence[np.ndarray], joints: int) -> np.ndarray:
    """One row per sample whose pairwise Euclidean distances are root-mean-square joint distances.

    ``frames`` are the samples' flattened poses ``(T_i, 3 J)``; all are cut to the shortest and
    scaled by ``1 / sqrt(frames * J)``.
    """
    n = min(len(f) for f in frames)
    return np.stack([f[:n].reshape(-1) for f in frames]) / np.sqrt(n * joints)


class SampleDiversity:
    """Mean pairwise distance between generated samples of the same song (pose and kinetic features)."""

    needs: tuple[str, ...] = ()

    def __init__(self, hips: list[str] | None = None):
        self.hips = hips

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """``Div_sample_pose`` (m), ``Div_sample_k`` and ``sample_songs`` (songs with two or more samples).

        A set without two samples of any song is compared as samples of one song, with a note and
        ``sample_songs`` 0: that is diversity across songs, what Div_k measures.
        """
        require_clips(generated, 2, WHAT)
        groups = songs_of(generated)
        songs = {song: idx for song, idx in groups.items() if len(idx) >= 2}
        notes = []
        if not songs:
            notes.append(
                f"{WHAT}: no song has two samples (files SONG-k); the {len(generated)} clips are compared "
                "as samples of one song (diversity across songs)"
            )
        elif len(songs) < len(groups):
            notes.append(f"{WHAT}: {len(groups) - len(songs)} song(s) with a single sample left out")
        poses, pose_notes = pose_windows(generated, 1, WHAT, hips=self.hips)
        kinetic, kinetic_notes = normalized_features(generated, reference, "kinetic", False, WHAT)
        joints = np.shape(generated[0].positions)[1]
        per_song = {
            song: {
                "Div_sample_pose": average_pairwise_distance(pose_distance_rows([poses[i] for i in idx], joints), WHAT),
                "Div_sample_k": average_pairwise_distance(kinetic[idx], WHAT),
                "samples": float(len(idx)),
            }
            for song, idx in (songs or {"all clips": list(range(len(generated)))}).items()
        }
        values = {k: float(np.mean([v[k] for v in per_song.values()])) for k in ("Div_sample_pose", "Div_sample_k")}
        values["sample_songs"] = float(len(songs))
        return MetricResult(values, per_song, notes + pose_notes + kinetic_notes)


def build_sample_diversity(config: Any, **_: Any) -> SampleDiversity:
    """``sample-diversity``."""
    return SampleDiversity(config.hips)
