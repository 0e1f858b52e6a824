"""Time FLUIDS' layout pipeline on a synthetic street grid of many lanes: validating the spec
(``LayoutSpec``), compiling it (``compile_layout`` with the road clearances and the off-road
tolerance area the simulator asks for) and the lane-marking pass of the renderer
(``sim/draw.py`` ``lane_markings``). Hashes the compiled drivable area and the markings, so two
checkouts can be compared side by side:

    PYTHONPATH=<checkout> python scripts/benchmarks/bench_layout.py --lanes 10000

The grid is one connected street network within the layout limit of ±1 km: square blocks,
every street segment two lanes (one per direction) that stop short of the junction squares,
which the kerb rounding joins into one drivable area with a hole per block. Prints JSON: the
lane count, CPU seconds per stage and sha256 digests (equal digests: identical output).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import time

import numpy as np
import shapely

from fluids_bench.core.provenance import announce
from fluids_bench.tasks.fluids.sim import draw
from fluids_bench.tasks.fluids.sim.layout.compiled import compile_layout
from fluids_bench.tasks.fluids.sim.layout.spec import CarRoute, Lane, LayoutSpec

BLOCK = 30.0  # m between junction centres
WIDTH = 3.5  # m per lane


def street_grid(count: int) -> LayoutSpec:
    """``count`` lanes: per junction, an eastward/westward pair and a northward/southward pair."""
    side = math.ceil(math.sqrt(count / 4))
    gap = WIDTH + 1.0  # lanes stop this far from a junction's centre
    lanes = []
    for i in range(side):
        for j in range(side):
            x, y = i * BLOCK - 900.0, j * BLOCK - 900.0
            ends = (
                ((x + gap, y - WIDTH / 2), (x + BLOCK - gap, y - WIDTH / 2)),
                ((x + BLOCK - gap, y + WIDTH / 2), (x + gap, y + WIDTH / 2)),
                ((x + WIDTH / 2, y + gap), (x + WIDTH / 2, y + BLOCK - gap)),
                ((x - WIDTH / 2, y + BLOCK - gap), (x - WIDTH / 2, y + gap)),
            )
            lanes += [Lane(f"l{i}_{j}_{d}", line, WIDTH) for d, line in enumerate(ends)]
    lanes = lanes[:count]
    route = CarRoute(lanes[0].name, lanes[min(5, len(lanes) - 1)].name)
    return LayoutSpec("street_grid", (-1000.0, -1000.0, 1000.0, 1000.0), tuple(lanes), (route,))


def _cpu(fn):
    start = time.process_time()
    value = fn()
    return value, round(time.process_time() - start, 3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--lanes", type=int, default=1024, help="lanes in the grid (>= 6)")
    args = parser.parse_args()
    if args.lanes < 6 or args.lanes > 40_000:
        parser.error(f"--lanes is {args.lanes}; allowed: 6 to 40000 (the grid must fit ±1 km)")
    announce("~3 s at 1,024 lanes, ~10 s at 10,000 on a free core")
    spec, validate_s = _cpu(lambda: street_grid(args.lanes))

    def compile_all():
        layout = compile_layout.__wrapped__(spec)  # not the cache: time the work
        layout.route_clearance, layout.drivable_tolerant  # noqa: B018 (computed on first use)
        return layout

    layout, compile_s = _cpu(compile_all)
    markings, markings_s = _cpu(lambda: draw.lane_markings.__wrapped__(layout))
    area = hashlib.sha256(shapely.to_wkb(shapely.normalize(layout.drivable))).hexdigest()
    digest = hashlib.sha256()
    for group in markings:
        digest.update(str(len(group)).encode())
        for poly in group:
            digest.update(np.ascontiguousarray(poly, dtype=np.float64).tobytes())
    out = {
        "lanes": len(spec.lanes),
        "cpu_seconds": {"validate": validate_s, "compile": compile_s, "markings": markings_s},
        "marking_counts": [len(g) for g in markings],
        "drivable_sha256": area,
        "markings_sha256": digest.hexdigest(),
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
