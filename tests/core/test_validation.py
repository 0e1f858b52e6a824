import pytest

from fluids_bench.core.validation import reject_unknown_kwargs


class E:
    @reject_unknown_kwargs
    def __init__(self, a=1, *, b=2):
        self.a, self.b = a, b


def test_unknown_kwarg_is_named_with_the_allowed_ones():
    with pytest.raises(ValueError, match=r"unknown argument\(s\) 'c'; allowed: \['a', 'b'\]"):
        E(c=3)
    assert E(a=5, b=6).a == 5
