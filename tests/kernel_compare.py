"""Comparing compiled kernels with the numpy formulations they replaced.

A kernel does the numpy formulation's arithmetic in the same order and precision, but its
transcendental functions (sin, cos, tan, atan, atan2, ...) are the C library's scalar ones,
while numpy may evaluate them with its own vectorised code. On CPUs with wide vector units
(AVX-512) the two differ in the last bit on a few percent of inputs, so a comparison of a
kernel with its numpy reference must not be exact wherever such a function feeds the result.

Stated tolerance: float64 results agree to ``rtol = atol = 1e-12`` (metres, radians, m/s: about
10^4 ulp, far below anything physical, far above the 1-ulp differences); float32 results
(observations) to ``rtol = atol = 1e-6`` (a few float32 ulp). Integer and boolean results
(indices, labels, pairs, on-road flags) are compared exactly: for one of them to differ, an
input would have to fall within an ulp of a decision threshold. Where both sides run the same
scalar code (the angle wrap, min/max), tests compare bit for bit.
"""

from __future__ import annotations

import numpy as np

FLOAT64 = {"rtol": 1e-12, "atol": 1e-12}
FLOAT32 = {"rtol": 1e-6, "atol": 1e-6}


def assert_kernel_close(got, want, msg: str = "") -> None:
    """Same dtype and shape; floats within the stated tolerance (NaN where NaN); others exact."""
    got, want = np.asarray(got), np.asarray(want)
    assert got.dtype == want.dtype and got.shape == want.shape, (msg, got.dtype, want.dtype)
    if np.issubdtype(got.dtype, np.floating):
        tol = FLOAT32 if got.dtype == np.float32 else FLOAT64
        np.testing.assert_allclose(got, want, equal_nan=True, err_msg=msg, **tol)
    else:
        np.testing.assert_array_equal(got, want, err_msg=msg)
