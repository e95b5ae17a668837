"""One training run of one family under the claims protocol: train to a plateau, compose the test songs
at each temperature, score, held-out NLL; the result cached as JSON (``claims_protocol.cached``)."""

from __future__ import annotations

import time
from pathlib import Path

from claims_protocol import MEMO, Protocol, TestSet, cached, generate, score, source, train_to_plateau


def run_family(protocol: Protocol, key: str, recipe_name: str, extra: list[str], seed: int, test: TestSet,
               reference, temperatures=(1.0,), homogeneous: bool = False, work: Path | None = None) -> dict:
    """Train ``recipe_name`` with the common overrides, ``extra`` and ``seed``; score ``samples`` dances per
    test song at every temperature; the held-out NLL of the test songs' real dances (None: no likelihood)."""

    def fresh() -> dict:
        from dance_core.api import held_out_nll, load_recipe

        MEMO.install()
        recipe = load_recipe(recipe_name, [*protocol.common(homogeneous), *extra, f"seed={seed}"])
        run = train_to_plateau(recipe, (work or protocol.cache / "work") / f"{key}-s{seed}", protocol)
        out = {"recipe": recipe_name, "extra": extra, "seed": seed, **run, "temperatures": {}}
        for t in temperatures:
            t0 = time.perf_counter()
            clips, speed = generate(recipe, run["checkpoint"], test.songs, test.beats, protocol.samples, t)
            out["temperatures"][f"{t:g}"] = {**score(clips, reference), "frames_per_s": speed,
                                             "generate_s": time.perf_counter() - t0}
        test_sources = [source(i, test.seconds, homogeneous) for i in _test_indices(test)]
        out["nll"] = held_out_nll(recipe, run["checkpoint"], test_sources, batches=4, batch_size=16)
        return out

    return cached(protocol, f"{key}-s{seed}", fresh)


def _test_indices(test: TestSet) -> list[int]:
    from claims_protocol import DANCES, TRAIN_SONGS

    return list(range(TRAIN_SONGS * DANCES, TRAIN_SONGS * DANCES + len(test.sources)))


def ground_truth(protocol: Protocol, test: TestSet, reference, key: str) -> dict:
    """The test songs' real dances scored like a model (several dances per song count as samples)."""

    def fresh() -> dict:
        return score(test.real, reference)  # SONG-k names: a song's dances count as its samples

    return cached(protocol, key, fresh)
