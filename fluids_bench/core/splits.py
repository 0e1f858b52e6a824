"""The benchmark's seed splits, and the guard that keeps training off the held-out seeds.

Seeds are split by range, the same for every task, so that the splits are disjoint by
construction and a training path can tell a held-out seed from the seed alone:

| split | seeds | who uses them |
| --- | --- | --- |
| train | `0` to `2**31 - 2` | data collection (`collect --seed`), the algorithm harness (it draws episode and evaluation seeds below `2**31 - 1`) |
| validation | `2_500_000_000 + i` | model selection, early stopping; never reported |
| test | `3_000_000_000 + i` | the benchmark's reported score only |
| out-of-distribution test | `3_500_000_000 + i` | the reported OOD scores only |

Every seed from [`HELD_OUT_START`][fluids_bench.core.splits.HELD_OUT_START] up (test and
OOD sets) is held out: [`refuse_test_seeds`][fluids_bench.core.splits.refuse_test_seeds]
is called by every training code path and raises a `ValueError` when one would be used.
"""

from __future__ import annotations

from collections.abc import Iterable

TRAIN_END = 2**31 - 1  # train seeds: 0 <= seed < TRAIN_END (the harness's draws stay below it)
VALIDATION_START = 2_500_000_000
TEST_START = 3_000_000_000
OOD_START = 3_500_000_000
HELD_OUT_START = TEST_START  # every seed from here on is held out from training
SEED_END = 2**32  # Gymnasium's and numpy's seeds: below 2**32
SPLITS = ("train", "validation", "test")


def split_seeds(split: str, count: int, offset: int = 0) -> list[int]:
    """The first `count` seeds of `split` (after `offset` of them).

    Args:
        split: `"train"`, `"validation"`, `"test"` or `"ood"`.
        count: how many seeds.
        offset: seeds of the split to skip first.

    Returns:
        The seeds, in order.
    """
    starts = {"train": 0, "validation": VALIDATION_START, "test": TEST_START, "ood": OOD_START}
    if split not in starts:
        raise ValueError(f"split is {split!r}; allowed: {sorted(starts)}")
    if count < 0 or offset < 0:
        raise ValueError(f"count {count} and offset {offset}; allowed: non-negative integers")
    return [starts[split] + offset + i for i in range(count)]


def split_of(seed: int) -> str:
    """Which split `seed` belongs to: `"train"`, `"validation"`, `"test"`, `"ood"` or
    `"unassigned"` (between the train and validation blocks)."""
    if seed < TRAIN_END:
        return "train"
    if VALIDATION_START <= seed < TEST_START:
        return "validation"
    if TEST_START <= seed < OOD_START:
        return "test"
    if OOD_START <= seed < SEED_END:
        return "ood"
    return "unassigned"


def refuse_test_seeds(seeds: int | Iterable[int], where: str) -> None:
    """Raise a `ValueError` if any of `seeds` is a held-out (test or OOD) seed.

    Called by every training code path (data collection, the algorithm harness) before its
    episodes run. A `range` is checked by its bounds, anything else seed by seed.

    Args:
        seeds: one seed, a `range` or an iterable of seeds.
        where: the code path, named in the error (e.g. `"collect"`).
    """
    if isinstance(seeds, int):
        seeds = (seeds,)
    if isinstance(seeds, range):
        top = max(seeds[0], seeds[-1]) if len(seeds) else -1  # a range is monotone
        bad = top if top >= HELD_OUT_START else None
    else:
        bad = next((int(s) for s in seeds if int(s) >= HELD_OUT_START), None)
    if bad is not None:
        raise ValueError(
            f"{where}: seed {bad} is one of the benchmark's held-out {split_of(bad)} seeds "
            f"(every seed >= {HELD_OUT_START:,} is reserved for fluids-bench evaluate); allowed "
            f"for training: seeds below {TRAIN_END:,} (the train split), or the validation "
            f"seeds from {VALIDATION_START:,}"
        )
