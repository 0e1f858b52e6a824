"""Gap acceptance on a constructed grid: a supervised car turning left across an oncoming ego.

Car 1 (supervised, defensive) waits ``--back`` metres before its junction entry at a starting
speed, about to turn left (east → south) across the ego (car 0), which comes straight from the
west at a constant target speed from a distance before the crossing. No lights, no walkers.
For every combination, runs until a collision or ``--steps`` steps and counts collisions by
fault (``info["collisions"]``). Prints JSON: the counts and the combinations that ended in the
turner's fault. ``tests/tasks/fluids/test_fair.py`` samples the grid.

    python scripts/checks/give_way_grid.py --layout t_junction
"""

from __future__ import annotations

import argparse
import itertools
import json

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.core.provenance import announce
from fluids_bench.tasks.fluids.sim.fault import FaultTracker
from fluids_bench.tasks.fluids.sim.layout.geometry import PATH_SPACING


def closest_s(path_a: np.ndarray, path_b: np.ndarray) -> float:
    """Arc length on path a of the point closest to path b."""
    d = np.hypot(*(path_a[:, None, :] - path_b[None, :, :]).transpose(2, 0, 1))
    return float(np.unravel_index(np.argmin(d), d.shape)[0] * PATH_SPACING)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--layout", choices=["four_way", "t_junction"], default="four_way")
    p.add_argument("--distances", type=float, nargs="+", default=[8, 12, 16, 20, 25, 30, 35, 40])
    p.add_argument("--ego-speeds", type=float, nargs="+", default=[3, 5, 7, 9])
    p.add_argument("--backs", type=float, nargs="+", default=[0.5, 3, 6, 10])
    p.add_argument("--turner-speeds", type=float, nargs="+", default=[0, 3, 6])
    p.add_argument("--steps", type=int, default=120)
    args = p.parse_args()
    announce("~1 min on one core per layout")
    env = gym.make(
        "FLUIDS-v0", layout=args.layout, num_cars=1, num_pedestrians=0,
        action_level="velocity", defensive=True, lights=False,
    )  # fmt: skip
    env.reset(seed=0)
    routes = env.unwrapped.world.layout.routes
    straight = routes.names.index("west_in_0->east_out_0")
    left = routes.names.index("east_in_0->south_out_0")
    crossing = closest_s(routes.path[straight], routes.path[left])
    counts = {"combinations": 0, "turner_at_fault": 0, "ego_at_fault": 0, "other": 0}
    bad = []
    grid = itertools.product(args.distances, args.ego_speeds, args.backs, args.turner_speeds)
    for d_ego, v_ego, back, v_turn in grid:
        env.reset(seed=0)
        u = env.unwrapped
        w = u.world
        w.place(0, straight, crossing - d_ego, speed=v_ego)
        w.place(1, left, float(routes.enter_s[left]) - back - w.length[1] / 2, speed=v_turn)
        u.faults = FaultTracker(w)
        u.supervisor.prepare(w)
        counts["combinations"] += 1
        for _ in range(args.steps):
            _, _, term, trunc, info = env.step(np.array([v_ego], np.float32))
            for c in info["collisions"]:
                if c["at_fault"] == [0]:
                    counts["ego_at_fault"] += 1
                elif 1 in c["at_fault"]:
                    counts["turner_at_fault"] += 1
                    bad.append([d_ego, v_ego, back, v_turn, c["rule"]])
                else:
                    counts["other"] += 1
            if info["collisions"] or term or trunc:
                break
    print(json.dumps({"layout": args.layout, **counts, "turner_at_fault_cases": bad}, indent=1))


if __name__ == "__main__":
    main()
