"""Where a cold compile of FLUIDS' kernels goes: CPU seconds per compiled function, split into
numba's Python side (bytecode to IR, typing, lowering to LLVM IR) and LLVM's three stages
(function passes as IR is added, the final module's O3 passes, machine code).

One case per run, in this process with an empty kernel cache (`NUMBA_CACHE_DIR` set to a new
temporary directory before numba is imported): import, `gym.make`, reset and 50 random steps,
as `bench_compile.py` measures it. Times are exclusive: a kernel compiled while its caller is
typed is charged to itself, not to the caller; numpy functions' implementations that numba
compiles on first use are listed under numba's names (`arrayobj.impl` and so on) with their
argument types. A caller's LLVM stages include its callees' code again (numba links each
callee's module into its caller's before optimising it).

    python scripts/benchmarks/profile_compile.py --case FLUIDS-v1 --top 30
"""

from __future__ import annotations

import argparse
import collections
import os
import tempfile
import time

STAGES = ("python", "llvm_add", "llvm_final", "machine_code")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", default="FLUIDS-v1", help="an env id, or 'vector'")
    parser.add_argument("--top", type=int, default=30, help="functions listed")
    args = parser.parse_args()
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="fluids-bench-profile-")
    from numba.core import codegen, event

    stack: list[str] = []
    stage = ["python"]
    spent: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    last = [time.process_time()]

    def charge() -> None:
        now = time.process_time()
        spent[stack[-1] if stack else "(outside compiles)"][stage[-1]] += now - last[0]
        last[0] = now

    class Compiles(event.Listener):
        def on_start(self, ev):
            charge()
            data = ev.data or {}
            f = getattr(data.get("dispatcher"), "py_func", None)
            name = f"{f.__module__.rsplit('.', 1)[-1]}.{f.__name__}" if f else "?"
            if name.endswith("impl"):
                name += str(data.get("args"))[:80]
            stack.append(name)
            stage.append("python")

        def on_end(self, ev):
            charge()
            stack.pop()
            stage.pop()

    event.register("numba:compile", Compiles())

    def timed(cls, method: str, name: str) -> None:
        original = getattr(cls, method)

        def wrapper(self, *a, **k):
            charge()
            stage.append(name)
            try:
                return original(self, *a, **k)
            finally:
                charge()
                stage.pop()

        setattr(cls, method, wrapper)

    timed(codegen.CPUCodeLibrary, "add_ir_module", "llvm_add")
    timed(codegen.CPUCodeLibrary, "_optimize_final_module", "llvm_final")
    timed(codegen.JITCodeLibrary, "_finalize_specific", "machine_code")

    t0 = time.process_time()
    import gymnasium as gym

    import fluids_bench  # noqa: F401

    if args.case == "vector":
        env = gym.make_vec("FLUIDS-v1", 4, vectorization_mode="vector_entry_point")
    else:
        env = gym.make(args.case)
    env.reset(seed=0)
    for _ in range(50):
        env.step(env.action_space.sample())
    charge()
    total = time.process_time() - t0
    sums = {s: sum(c[s] for c in spent.values()) for s in STAGES}
    print(f"{args.case}: {total:.1f} CPU-s; " + ", ".join(f"{s} {v:.1f}" for s, v in sums.items()))
    rows = sorted(spent.items(), key=lambda kv: -sum(kv[1].values()))
    for name, c in rows[: args.top]:
        parts = " ".join(f"{s}={c[s]:5.2f}" for s in STAGES)
        print(f"{sum(c.values()):6.2f}  {parts}  {name}")


if __name__ == "__main__":
    main()
