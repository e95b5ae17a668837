"""One training run of one family under the claims protocol: train to a plateau, compose the test songs
at each temperature, score, held-out NLL; the result cached as JSON (``claims_protocol.cached``)."""

from __future__ import annotations

import time
from pathlib import Path

from claims_protocol import (
    MEMO,
    Protocol,
    TestSet,
    cached,
    choose_then_score,
    generate,
    score,
    source,
    train_to_plateau,
)


def run_family(protocol: Protocol, key: str, recipe_name: str, extra: list[str], seed: int, test: TestSet,
               reference, temperatures=(1.0,), homogeneous: bool = False, work: Path | None = None,
               select: TestSet | None = None) -> dict:
    """Train ``recipe_name`` with the common overrides, ``extra`` and ``seed``; with several temperatures,
    choose one on the ``select`` songs (required then) and score ``samples`` dances per test song at that
    one only (``choose_then_score``); the held-out NLL of the test songs' real dances (None: no
    likelihood)."""
    if len(temperatures) > 1 and select is None:
        raise ValueError("claims: a temperature sweep needs selection songs (never the test songs)")

    def fresh() -> dict:
        from dance_core.api import held_out_nll, load_recipe

        MEMO.install()
        recipe = load_recipe(recipe_name, [*protocol.common(homogeneous), *extra, f"seed={seed}"])
        run = train_to_plateau(recipe, (work or protocol.cache / "work") / f"{key}-s{seed}", protocol)

        def scores(songs: TestSet, t: float) -> dict:
            t0 = time.perf_counter()
            clips, speed = generate(recipe, run["checkpoint"], songs.songs, songs.beats, protocol.samples, t)
            return {**score(clips, reference, protocol.metrics()), "frames_per_s": speed,
                    "generate_s": time.perf_counter() - t0}

        out = {"recipe": recipe_name, "extra": extra, "seed": seed, **run,
               **choose_then_score(temperatures, lambda t: scores(select, t), lambda t: scores(test, t))}
        graph = protocol.graph(homogeneous)
        test_sources = [source(i, test.seconds, homogeneous, graph) for i in _test_indices(test)]
        out["nll"] = held_out_nll(recipe, run["checkpoint"], test_sources, batches=4, batch_size=16)
        return out

    return cached(protocol, f"{key}-s{seed}", fresh)


def _test_indices(test: TestSet) -> list[int]:
    from claims_protocol import DANCES, TRAIN_SONGS

    return list(range(TRAIN_SONGS * DANCES, TRAIN_SONGS * DANCES + len(test.sources)))


def ground_truth(protocol: Protocol, test: TestSet, reference, key: str) -> dict:
    """The test songs' real dances scored like a model (several dances per song count as samples)."""

    def fresh() -> dict:
        return score(test.real, reference, protocol.metrics())  # SONG-k names: a song's dances count as its samples

    return cached(protocol, key, fresh)
