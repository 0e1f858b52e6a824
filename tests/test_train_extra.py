"""The markers for tests that need an optional piece (tests/train_extra.py): without the piece
they skip with the stated reason, under CI's variable they fail, and an unmarked test that needs
the train extra fails (CI's second phase, `-m "train_extra or browser or client_extra"`, would never run it)."""

from __future__ import annotations

import re

import pytest
import train_extra


@pytest.fixture
def no_train_extra(monkeypatch):
    monkeypatch.setattr(train_extra, "TRAIN_MODULES", ("torch", "fluids_bench_no_such_module"))
    monkeypatch.delenv(train_extra.TRAIN_ENV, raising=False)
    return monkeypatch


def test_a_missing_module_of_the_train_extra_skips_with_the_reason(no_train_extra):
    assert train_extra.missing_train_modules()[-1] == "fluids_bench_no_such_module"
    with pytest.raises(pytest.skip.Exception, match=re.escape(train_extra.REASON)):
        train_extra.require_train_extra()


def test_under_ci_s_variable_a_missing_module_fails(no_train_extra):
    no_train_extra.setenv(train_extra.TRAIN_ENV, "1")
    with pytest.raises(pytest.fail.Exception, match="FLUIDS_BENCH_TRAIN_TESTS=1 but"):
        train_extra.require_train_extra()


def test_a_missing_browser_skips_and_fails_under_ci_s_variable(monkeypatch):
    monkeypatch.setattr(train_extra, "chromium", lambda: None)
    monkeypatch.delenv(train_extra.BROWSER_ENV, raising=False)
    with pytest.raises(pytest.skip.Exception, match=re.escape(train_extra.BROWSER_REASON)):
        train_extra.require_browser()
    monkeypatch.setenv(train_extra.BROWSER_ENV, "1")
    with pytest.raises(pytest.fail.Exception, match="FLUIDS_BENCH_BROWSER_TESTS=1 but"):
        train_extra.require_browser()


def test_an_unmarked_test_that_needs_the_train_extra_fails():
    assert not train_extra.current_test_is_marked
    with pytest.raises(pytest.fail.Exception, match="mark it @pytest.mark.train_extra"):
        train_extra.require_sb3()


@pytest.mark.train_extra
def test_a_marked_test_gets_stable_baselines3():
    assert train_extra.current_test_is_marked
    assert train_extra.require_sb3().__name__ == "stable_baselines3"
