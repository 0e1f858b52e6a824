"""Time FLUIDS' lane-marking pass (``sim/draw.py`` ``lane_markings``) on a synthetic layout of
many lanes, and hash its output, so two checkouts can be compared side by side:

    PYTHONPATH=<checkout> python3 scripts/benchmarks/bench_lane_markings.py --lanes 1024

A grid of straight two-way roads, each two lanes per direction (so centre lines, dashes and
kerbs all occur), 40 m long and 30 m apart. Prints JSON: lanes, seconds, and a sha256 of the
marking polylines (equal hashes: identical markings).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import time

import numpy as np

from fluids_bench.core.provenance import announce
from fluids_bench.tasks.fluids.sim import draw
from fluids_bench.tasks.fluids.sim.layout.spec import Lane


class _Spec:
    def __init__(self, lanes: tuple[Lane, ...]) -> None:
        self.lanes, self.entry_lanes = lanes, ()


class _Layout:  # what lane_markings reads of a compiled Layout
    def __init__(self, lanes: tuple[Lane, ...]) -> None:
        self.spec = _Spec(lanes)


def grid_lanes(count: int, width: float = 3.5) -> tuple[Lane, ...]:
    roads = max(1, count // 4)
    side = math.ceil(math.sqrt(roads))
    lanes = []
    for r in range(roads):
        x0, y0 = (r % side) * 60.0, (r // side) * 30.0
        for k, (sign, off) in enumerate(((1, -0.5), (1, -1.5), (-1, 0.5), (-1, 1.5))):
            y = y0 + off * width
            a, b = (x0, y), (x0 + 40.0, y)
            line = (a, b) if sign > 0 else (b, a)
            lanes.append(Lane(f"r{r}_{k}", line, width))
    return tuple(lanes[:count])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--lanes", type=int, default=1024)
    args = parser.parse_args()
    announce("~10 s at 1,024 lanes")
    layout = _Layout(grid_lanes(args.lanes))
    start = time.perf_counter()
    markings = draw.lane_markings.__wrapped__(layout)
    seconds = time.perf_counter() - start
    digest = hashlib.sha256()
    for group in markings:
        digest.update(str(len(group)).encode())
        for poly in group:
            digest.update(np.ascontiguousarray(poly, dtype=np.float64).tobytes())
    counts = [len(g) for g in markings]
    out = {"lanes": args.lanes, "seconds": round(seconds, 3), "counts": counts}
    print(json.dumps({**out, "sha256": digest.hexdigest()}))


if __name__ == "__main__":
    main()
