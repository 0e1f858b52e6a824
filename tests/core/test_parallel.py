"""Pool workers compute with one BLAS thread (``core/parallel.py: one_blas_thread``), including the
BLAS and OpenMP libraries a worker loads only after it starts (SciPy's OpenBLAS, scikit-learn's
OpenMP), in the library's pools and in the scripts' plain ``ProcessPoolExecutor``s."""

from __future__ import annotations

import json
import operator
import os
import subprocess
import sys
import textwrap

import pytest

from fluids_bench.core.parallel import BLAS_THREAD_VARIABLES, as_finished

PROBE = textwrap.dedent(
    """
    import json
    from concurrent.futures import ProcessPoolExecutor
    from threadpoolctl import threadpool_info
    from fluids_bench.core.parallel import one_blas_thread, process_pool

    def threads():
        import scipy.linalg, sklearn.neural_network  # loaded after the worker started
        return sorted({(i["internal_api"], i["num_threads"]) for i in threadpool_info()})

    if __name__ == "__main__":
        with ProcessPoolExecutor(1, initializer=one_blas_thread) as pool:
            plain = pool.submit(threads).result()
        with process_pool(1, "spawn") as pool:
            library = pool.submit(threads).result()
        print(json.dumps({"caller": threads(), "plain": plain, "library": library}))
    """
)


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: BLAS runs one thread anyway")
def test_pool_workers_run_one_blas_thread(tmp_path):
    script = tmp_path / "probe.py"
    script.write_text(PROBE)
    env = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}
    out = subprocess.run(
        [sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    found = json.loads(out.stdout.splitlines()[-1])
    # the caller keeps its libraries' defaults: several threads on this machine
    assert max(n for _, n in found["caller"]) > 1, found
    for pool in ("plain", "library"):
        apis = {api for api, _ in found[pool]}
        assert {"openblas", "openmp"} <= apis, found
        assert all(n == 1 for _, n in found[pool]), (pool, found)


@pytest.mark.parametrize("workers", [1, 2])
def test_as_finished_returns_every_job_with_its_index(workers):
    jobs = [(i, 10) for i in range(5)]
    assert sorted(as_finished(operator.pow, jobs, workers)) == [(i, i**10) for i in range(5)]
