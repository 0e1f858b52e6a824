"""Registry-driven: an unknown keyword argument to any registered env raises a ``TypeError`` (as
Python does, and as wrappers such as TorchRL's ``GymEnv`` probe for) that is also a ``ValueError``
and keeps the suite's message naming the argument and listing the allowed ones."""

from __future__ import annotations

import gymnasium as gym
import pettingzoo
import pytest

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.validation import UnknownArgumentError
from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS

GYM_IDS = sorted(ENV_SPECS)
PARALLEL_IDS = sorted(PARALLEL_ENV_SPECS)
VECTOR_IDS = [i for i in GYM_IDS if gym.spec(i).vector_entry_point is not None]
# the suite's wording, then Python's (the part TorchRL matches on)
MESSAGE = (
    r": unknown argument\(s\) 'frameskip'; allowed: \[.+\] "
    r"\(__init__\(\) got an unexpected keyword argument 'frameskip'\)"
)


def _check(error: pytest.ExceptionInfo) -> None:
    assert isinstance(error.value, TypeError) and isinstance(error.value, ValueError)
    assert type(error.value) is UnknownArgumentError
    assert "unexpected keyword argument 'frameskip'" in str(error.value)


@pytest.mark.parametrize("env_id", GYM_IDS)
def test_gymnasium_ids_raise_type_error_for_an_unknown_argument(env_id):
    with pytest.raises(TypeError, match=MESSAGE) as error:
        gym.make(env_id, frameskip=4)
    _check(error)


@pytest.mark.parametrize("env_id", VECTOR_IDS)
def test_vector_entry_points_raise_type_error_for_an_unknown_argument(env_id):
    for workers in (1, 2):
        with pytest.raises(TypeError, match=MESSAGE) as error:
            gym.make_vec(
                env_id, 2, vectorization_mode="vector_entry_point", num_workers=workers, frameskip=4
            )
        _check(error)


@pytest.mark.parametrize("env_id", PARALLEL_IDS)
def test_pettingzoo_ids_raise_type_error_for_an_unknown_argument(env_id):
    with pytest.raises(TypeError, match=MESSAGE) as error:
        pettingzoo.make("parallel", env_id, frameskip=4)
    _check(error)


def test_several_unknown_arguments_are_all_named_and_the_first_in_pythons_words():
    with pytest.raises(ValueError, match=r"unknown argument\(s\) 'a_bad', 'b_bad'; allowed: ") as e:
        gym.make("GridWorld-v0", b_bad=1, a_bad=2)
    assert "(__init__() got an unexpected keyword argument 'a_bad')" in str(e.value)
