"""Fixtures shared by the algorithm tests."""

from __future__ import annotations

from typing import Any

import pytest

from fluids_bench.algos.harness import Harness


@pytest.fixture
def fits(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Training-set sizes of every fit an algorithm asks for (Harness.fit)."""
    sizes: list[int] = []
    original = Harness.fit

    def spy(self: Harness) -> Any:
        sizes.append(len(self.train))
        return original(self)

    monkeypatch.setattr(Harness, "fit", spy)
    return sizes
