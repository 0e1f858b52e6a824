"""`fluids-bench demo` for the PettingZoo ids (`FLUIDS-MultiAgent-v*`): one seeded
episode through PettingZoo's ParallelEnv API, every agent following its own supervisor label
(`infos[agent]["supervisor_action"]`). The snapshot is the first collision of a controlled
car if there is one, else the moment the live agents are nearest the junction's centre (on
average); the summary counts arrivals, successes and collisions per agent."""

from __future__ import annotations

import argparse
import time

import numpy as np

from fluids_bench.commands.demo_output import SNAPSHOT_NAME, Recorder, progress_bar, write_png
from fluids_bench.core.supervisor import SUPERVISOR_ACTION_KEY


def run_parallel(args: argparse.Namespace) -> int:
    from fluids_bench.registration import make_parallel_env

    kwargs = {"render_mode": "rgb_array"}
    if args.layout is not None:
        kwargs["layout"] = args.layout
    if args.steps is not None:
        kwargs["max_cycles"] = args.steps  # PettingZoo's name for the step limit
    env = make_parallel_env(args.env, **kwargs)
    limit = env.max_cycles
    args.out.mkdir(parents=True, exist_ok=True)
    _, infos = env.reset(seed=args.seed)
    world = env.world
    index = {agent: i for i, agent in enumerate(env.possible_agents)}
    centre = np.mean(np.reshape(world.layout.bounds, (2, 2)), axis=0)
    fps = env.metadata.get("render_fps") or 10
    recorder = Recorder(env.render, args.out, fps, not args.no_video, args.frame_every, limit)

    def spread() -> float:
        live = [index[a] for a in env.agents]
        return float(np.mean(np.hypot(*(world.state[live, :2] - centre).T))) if live else np.inf

    best = np.inf

    def consider(step: int, score: float, last: bool) -> None:
        nonlocal best
        frame = recorder.frame(step, last)
        if score < best:
            best = score
            recorder.snapshot = frame if frame is not None else env.render()

    steps, sim_seconds, returns = 0, 0.0, dict.fromkeys(env.possible_agents, 0.0)
    final: dict[str, dict] = {}
    collided: set[str] = set()
    bar = progress_bar(limit, args.env, args.no_progress)
    try:
        consider(0, spread(), False)
        while env.agents:
            actions = {agent: infos[agent][SUPERVISOR_ACTION_KEY] for agent in env.agents}
            t0 = time.perf_counter()
            _, rewards, terminations, truncations, infos = env.step(actions)
            sim_seconds += time.perf_counter() - t0
            steps += 1
            bar.update(1)
            hit = False
            for agent, reward in rewards.items():
                returns[agent] += float(reward)
                if infos[agent].get("collisions"):
                    hit = hit or agent not in collided
                    collided.add(agent)
                if terminations[agent] or truncations[agent]:
                    final[agent] = infos[agent]
            # a controlled car's first collision wins the snapshot (drawn after the step,
            # which already removed the wreck: the cars around it are still there)
            consider(steps, -1.0 if hit and best >= 0 else spread(), not env.agents)
    finally:
        bar.close()
        recorder.close()
        env.close()
    write_png(args.out / SNAPSHOT_NAME, recorder.snapshot)
    agents = env.possible_agents
    arrived = sum(bool(final.get(a, {}).get("arrived")) for a in agents)
    success = sum(bool(final.get(a, {}).get("is_success")) for a in agents)
    print(
        f"{args.env} demo (PettingZoo ParallelEnv): seed {args.seed}, {len(agents)} agents, "
        "each following its supervisor label"
    )
    print(
        f"  success: {success}/{len(agents)}   arrived: {arrived}/{len(agents)}   "
        f"in a collision: {len(collided)}   steps: {steps}   "
        f"mean return: {np.mean(list(returns.values())):.3f}"
    )
    print(
        f"  simulation: {steps / max(sim_seconds, 1e-9):.0f} steps/s ({steps} steps in "
        f"{sim_seconds:.2f} s; drawing and video not counted)"
    )
    print("  wrote " + " and ".join(recorder.wrote()))
    return 0
