"""Label purity and exact continuation after restoring a state, per id, printed as JSON.

For each id, drive ``--states`` steps with a random learner and as many with a noisy
supervisor (the label plus N(0, (0.3 half-range)²) for Box actions; the label with
probability 0.7 for Discrete ones), resetting with the next seed when an episode ends. At
every state, copy the env and count how often the copy's ``supervisor_action()`` differs from
the label of the env that drove there (``label``), and how often the copy's next ``--ahead``
steps under the driving env's actions differ from the driving env's in anything it returns
(``continuation``). The copy is made by

* ``--copy snapshot``: ``env.unwrapped.snapshot()`` (with ``TimeLimit``'s count), pickled,
  restored into another ``gym.make`` env reset with another seed (the contract of issue #27);
* ``--copy deepcopy``: ``copy.deepcopy`` of the wrapped env (also runs on revisions without
  snapshots: compare with ``PYTHONPATH=/path/to/old``);
* ``--copy fresh``: the snapshot copy with its supervisor replaced by one constructed anew
  from the restored state (no plan, no held targets, no integrators: what DAgger's theory
  calls pi*(s)). A restored supervisor carries the driving env's plan, so only this mode sees
  a label that depends on history. Supervisors with no memory to drop (a value table, a search
  or a policy evaluated on the state) are kept; ``fresh`` in the output says which were
  rebuilt. Its ``continuation`` counts are meaningless (the fresh supervisor drives the
  background on) and reported as ``null``.

    PYTHONPATH=. python scripts/checks/supervisor_purity.py --ids Singulation-v0 --states 60

With ``--results FILE`` the ids measured are also merged into FILE (written atomically): their
rows replace any of the same id, the other ids' rows are kept, and the command that measured
each id is kept next to it (``commands``). The docs' table reads
``docs/results/supervisor_purity_fresh.json``, made with ``--copy fresh --states 30``.
"""

from __future__ import annotations

import argparse
import copy
import json
import pickle
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.registration import ENV_SPECS

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from exact_compare import exactly_equal  # noqa: E402

from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.provenance import announce, relative_paths

SEED = 20_000  # seeds the project's tests and tables do not use


def _act(env, kind, rng, info):
    space = env.action_space
    if kind == "random":
        return space.sample()
    label = info["supervisor_action"]
    if isinstance(space, gym.spaces.Discrete):
        return label if rng.random() < 0.7 else space.sample()
    low, high = space.low.astype(np.float64), space.high.astype(np.float64)
    noisy = label + 0.3 * (high - low) / 2 * rng.standard_normal(space.shape)
    return np.clip(noisy, low, high).astype(space.dtype)


def _copy(env, env_id, how, k, kwargs=None):
    if how == "deepcopy":
        return copy.deepcopy(env)
    from fluids_bench.core import snapshot

    saved = pickle.loads(pickle.dumps(snapshot.snapshot(env)))
    target = gym.make(env_id, **(kwargs or {}))
    target.reset(seed=SEED + 10_000 + k)
    snapshot.restore(target, saved)
    return target


def _fresh_supervisor(env) -> bool:
    """Replace ``env``'s supervisor by one built anew from its current state; False when its
    supervisor keeps no memory between labels (nothing to replace)."""
    inner = env.unwrapped
    name = type(inner).__name__
    if name == "FluidsEnv":
        from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor

        inner.supervisor = DrivingSupervisor(inner.world, inner.supervisor_config)
        inner.supervisor.prepare(inner.world)
        return True
    if name == "SingulationEnv":
        from fluids_bench.tasks.singulation.supervisor import SingulationSupervisor

        inner._supervisor = SingulationSupervisor()
        return True
    if name == "GraspingInClutterEnv":
        from fluids_bench.tasks.grasping.supervisor import GraspSupervisor

        inner.supervisor = GraspSupervisor(inner.cfg, foresight=inner.foresight)
        inner.supervisor.reset()
        inner._label = None
        return True
    return False


def measure(
    env_id: str, kind: str, states: int, ahead: int, how: str, kwargs: dict | None = None
) -> dict:
    env = gym.make(env_id, **(kwargs or {}))
    env.action_space.seed(SEED)
    rng = np.random.default_rng(SEED)
    episode = 0
    _, info = env.reset(seed=SEED)
    label_diff = cont_diff = 0
    active = []  # [copy, steps left]
    fresh = None
    for k in range(states):
        action = _act(env, kind, rng, info)
        clone = _copy(env, env_id, "snapshot" if how == "fresh" else how, k, kwargs)
        if how == "fresh":
            fresh = _fresh_supervisor(clone)
        if not exactly_equal(clone.unwrapped.supervisor_action(), info["supervisor_action"]):
            label_diff += 1
        if how != "fresh":
            active.append([clone, ahead, False])
        step = env.step(action)
        for entry in active:
            if not exactly_equal(list(step), list(entry[0].step(action))):
                entry[2] = True
            entry[1] -= 1
        done = step[2] or step[3]
        finished = [e for e in active if e[1] == 0 or done]
        cont_diff += sum(e[2] for e in finished)
        active = [e for e in active if not (e[1] == 0 or done)]
        info = step[4]
        if done:
            episode += 1
            _, info = env.reset(seed=SEED + episode)
    cont_diff += sum(e[2] for e in active)
    if how == "fresh":
        return {"states": states, "label": label_diff, "continuation": None, "fresh": fresh}
    return {"states": states, "label": label_diff, "continuation": cont_diff}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ids", nargs="+", default=sorted(ENV_SPECS))
    parser.add_argument("--states", type=int, default=60, help="states per driver and id")
    parser.add_argument("--ahead", type=int, default=2, help="steps compared after each copy")
    parser.add_argument("--copy", choices=["snapshot", "deepcopy", "fresh"], default="snapshot")
    parser.add_argument("--env-kwargs", default="{}", help="JSON kwargs for every gym.make")
    parser.add_argument("--results", default=None, help="JSON file to merge the ids' rows into")
    args = parser.parse_args()
    announce("~2 min on one core at --states 60")
    kwargs = json.loads(args.env_kwargs)
    out = {
        env_id: {
            kind: measure(env_id, kind, args.states, args.ahead, args.copy, kwargs)
            for kind in ("random", "noisy")
        }
        for env_id in args.ids
    }
    summary = {"copy": args.copy, "ahead": args.ahead, "env_kwargs": kwargs, "results": out}
    print(json.dumps(summary, indent=1))
    if args.results:
        command = "python scripts/checks/supervisor_purity.py " + " ".join(
            relative_paths(sys.argv[1:])
        )
        write_json_atomic(args.results, merge(args.results, summary, command))


def merge(path: str, summary: dict, command: str) -> dict:
    """The results file at `path` (if any) with `summary`'s ids replaced or added; refuses
    to mix copy modes, `--ahead` or env kwargs in one file."""
    try:
        with open(path) as f:
            data = json.load(f)
    except FileNotFoundError:
        data = {k: summary[k] for k in ("copy", "ahead", "env_kwargs")}
        data["results"], data["commands"] = {}, {}
    for key in ("copy", "ahead", "env_kwargs"):
        if data.get(key, {} if key == "env_kwargs" else None) != summary[key]:
            raise SystemExit(
                f"{path} holds --{key.replace('_', '-')} {data.get(key)!r}, this run "
                f"{summary[key]!r}: write to another file"
            )
    commands = data.setdefault("commands", {})
    if "command" in data:  # one command for every id (files written before --results)
        old = data.pop("command")
        for env_id in data["results"]:
            commands.setdefault(env_id, old)
    for env_id, rows in summary["results"].items():
        data["results"][env_id] = rows
        commands[env_id] = command
    return data


if __name__ == "__main__":
    main()
