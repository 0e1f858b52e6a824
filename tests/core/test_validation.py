import numpy as np
import pytest

from fluids_bench.core.validation import (
    check_bool,
    check_float,
    check_int,
    finite_float,
    reject_unknown_kwargs,
)


class E:
    @reject_unknown_kwargs
    def __init__(self, a=1, *, b=2):
        self.a, self.b = a, b


def test_unknown_kwarg_is_named_with_the_allowed_ones():
    with pytest.raises(ValueError, match=r"unknown argument\(s\) 'c'; allowed: \['a', 'b'\]"):
        E(c=3)
    assert E(a=5, b=6).a == 5


def test_numpy_scalars_count_as_python_numbers_and_bools_as_neither():
    assert (
        check_int("w", "n", np.int64(3), 0, 5) == 3
        and type(check_int("w", "n", np.int8(3), 0)) is int
    )
    assert check_float("w", "x", np.float32(0.5), 0.0, 1.0) == 0.5
    assert check_float("w", "x", np.int64(1), 0.0, 1.0) == 1.0
    assert check_bool("w", "b", np.bool_(True)) is True
    for bad in (True, np.bool_(False), "3", 3.0, np.float64(3.0)):
        with pytest.raises(ValueError, match="field 'n'"):
            check_int("w", "n", bad, 0, 5)
    for bad in (True, np.bool_(True), "0.5", 1j, np.complex64(1)):
        with pytest.raises(ValueError, match="field 'x'"):
            check_float("w", "x", bad, 0.0, 1.0)
    with pytest.raises(ValueError, match="field 'b' is 1; allowed: true or false"):
        check_bool("w", "b", 1)


def test_ints_beyond_a_floats_range_are_refused_not_overflowed():
    # float(10**400) raises OverflowError: it was the error users saw (issue #44)
    for bad in (10**400, -(10**400), np.inf, np.nan):
        with pytest.raises(ValueError, match=r"field 'dt' is .*; allowed: a finite number"):
            check_float("w", "dt", bad, 0.01, 0.5)
    assert finite_float(10**400) is None and finite_float(True) is None
    assert finite_float(np.float32(0.5)) == 0.5 and finite_float(10**300) == 1e300
    with pytest.raises(ValueError, match="field 'n' is 1000"):
        check_int("w", "n", 10**400, 0, 5)
