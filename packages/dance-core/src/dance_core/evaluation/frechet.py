"""Fréchet distance between Gaussians fitted to feature sets, normalization and diversity."""

from __future__ import annotations

import numpy as np

from dance_core.errors import DataError

#: reference-feature standard deviations below this are treated as 1 (the feature is not rescaled)
STD_FLOOR = 1e-8


def gaussian(x: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Mean and unbiased covariance of the rows of ``x (N, D)``; needs N >= 2."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or len(x) < 2:
        raise DataError(f"{what}: a Fréchet distance needs at least 2 samples per set; got {len(x)}")
    return x.mean(axis=0), np.atleast_2d(np.cov(x, rowvar=False))


def _sqrt_psd(m: np.ndarray) -> np.ndarray:
    """Symmetric square root of a symmetric positive semi-definite matrix (negative noise clipped)."""
    vals, vecs = np.linalg.eigh((m + m.T) / 2)
    return (vecs * np.sqrt(np.clip(vals, 0.0, None))) @ vecs.T


def frechet_distance(mu1: np.ndarray, cov1: np.ndarray, mu2: np.ndarray, cov2: np.ndarray) -> float:
    """``|mu1 - mu2|^2 + tr(C1) + tr(C2) - 2 tr((C1 C2)^1/2)``.

    ``tr((C1 C2)^1/2)`` is computed as ``tr((S C2 S)^1/2)`` with ``S = C1^1/2``: the matrix inside
    is symmetric positive semi-definite, so its eigenvalues are real and no complex square root
    (or silent ``.real``) is needed, even for rank-deficient covariances.
    """
    s = _sqrt_psd(cov1)
    inner = s @ cov2 @ s
    vals = np.linalg.eigvalsh((inner + inner.T) / 2)
    tr_sqrt = np.sqrt(np.clip(vals, 0.0, None)).sum()
    diff = mu1 - mu2
    value = float(diff @ diff + np.trace(cov1) + np.trace(cov2) - 2.0 * tr_sqrt)
    return max(value, 0.0)


def set_distance(a: np.ndarray, b: np.ndarray, what: str) -> float:
    """Fréchet distance between Gaussians fitted to two sets of feature vectors."""
    if a.shape[1:] != b.shape[1:]:
        raise DataError(f"{what}: feature widths differ ({a.shape[1]} vs {b.shape[1]})")
    return frechet_distance(*gaussian(a, what), *gaussian(b, what))


def normalize(reference: np.ndarray, *sets: np.ndarray, compat: bool = False) -> list[np.ndarray]:
    """Z-normalize every set with the reference set's mean and standard deviation.

    ``compat=True`` divides by ``std + 1e-10`` like Bailando; otherwise features whose reference
    standard deviation is below ``STD_FLOOR`` are only centred (no division by ~0).
    """
    mean = reference.mean(axis=0)
    std = reference.std(axis=0)
    scale = std + 1e-10 if compat else np.where(std > STD_FLOOR, std, 1.0)
    return [(x - mean) / scale for x in (reference, *sets)]


def average_pairwise_distance(x: np.ndarray, what: str) -> float:
    """Mean Euclidean distance over all unordered pairs of rows (Div_k / Div_g)."""
    x = np.asarray(x, dtype=np.float64)
    if len(x) < 2:
        raise DataError(f"{what}: diversity needs at least 2 clips; got {len(x)}")
    sq = (x**2).sum(axis=1)
    d2 = np.clip(sq[:, None] + sq[None, :] - 2 * x @ x.T, 0.0, None)
    iu = np.triu_indices(len(x), k=1)
    return float(np.sqrt(d2[iu]).mean())
