"""Learning from recorded datasets: BC on teleop data, DAgger with retroactive labels.

`load_pairs` reads the state–label pairs of Minari datasets (`observations[t]`,
`actions[t]`: the person's actions for teleop data, the new labels for relabelled data).
`fit` fits a learner on them (`fluids_bench.algos.policies`) and `evaluate`
rolls it out.

`retroactive_dagger` is DAgger as the source ran it with people (ch. 5): start from
teleoperated demonstrations, then each iteration collect the current learner's rollouts as a
dataset (`fluids-bench collect`'s format), have them labelled offline (the relabelling tool,
here with a `SimulatedHuman`), aggregate the labelled
pairs and refit. Every dataset it makes is written under `namespace`, so each step can be
inspected (or done by a person with `fluids-bench relabel`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import minari
import numpy as np

from fluids_bench.algos.actors import LearnerActor
from fluids_bench.algos.policies import FittedPolicy, PolicySpec, fit_policy
from fluids_bench.algos.rollout import rollout
from fluids_bench.human.relabelling import relabelled_episodes
from fluids_bench.human.simulated import SimulatedHuman


def load_pairs(dataset_ids: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """Observations (flattened) and labels of every step of the datasets, concatenated."""
    xs, ys = [], []
    for dataset_id in dataset_ids:
        for ep in minari.load_dataset(dataset_id).iterate_episodes():
            obs = np.asarray(ep.observations)
            xs.append(obs[:-1].reshape(len(ep.actions), -1))
            ys.append(np.asarray(ep.actions))
    if not xs:
        raise ValueError(f"datasets {list(dataset_ids)} hold no steps")
    return np.concatenate(xs), np.concatenate(ys)


def fit(
    dataset_ids: Sequence[str], env: gym.Env, policy: PolicySpec, seed: int = 0
) -> FittedPolicy:
    """Behaviour cloning: `policy` fit on the pairs of `dataset_ids`."""
    x, y = load_pairs(dataset_ids)
    return fit_policy(policy, env.action_space, x, y, random_state=seed)


def supervisor_return(
    env: gym.Env, episodes: int, seed: int, max_steps: int | None = None
) -> float:
    """Mean return of the supervisor on the evaluation episodes (the reference)."""
    from fluids_bench.algos.actors import SUPERVISOR

    return float(
        np.mean(
            [rollout(env, SUPERVISOR, seed + i, max_steps).total_return for i in range(episodes)]
        )
    )


def evaluate(
    policy: FittedPolicy, env: gym.Env, episodes: int, seed: int, max_steps: int | None = None
) -> dict[str, float]:
    """Mean return and success rate of `policy` over `episodes` seeded episodes."""
    returns, successes = [], []
    for i in range(episodes):
        trajectory = rollout(env, LearnerActor(policy), seed + i, max_steps)
        returns.append(trajectory.total_return)
        successes.append(bool(trajectory.infos[-1].get("is_success", False)))
    return {"mean_return": float(np.mean(returns)), "success_rate": float(np.mean(successes))}


@dataclass(frozen=True)
class DaggerIteration:
    iteration: int
    datasets: tuple[str, ...]  # the labelled datasets aggregated so far
    pairs: int
    labels_changed: float  # share of relabelled states whose label differs from the learner's
    mean_return: float
    success_rate: float


def retroactive_dagger(
    env_id: str,
    teleop_dataset: str,
    *,
    env_kwargs: dict[str, Any] | None = None,
    namespace: str = "human-dagger",
    iterations: int = 3,
    rollouts: int = 2,
    labeller: SimulatedHuman | None = None,
    policy: PolicySpec | None = None,
    eval_episodes: int = 5,
    seed: int = 0,
    max_steps: int | None = None,
) -> list[DaggerIteration]:
    """DAgger with retroactive labels (see the module docstring); one record per iteration,
    iteration 0 being BC on `teleop_dataset`."""
    from fluids_bench.data.collect import ActorSpec, collect
    from fluids_bench.data.minari_export import export_minari
    from fluids_bench.human.recording import load_episodes, spec_of, write_dataset
    from fluids_bench.human.session import Relabel

    kwargs = dict(env_kwargs or {})
    labeller = labeller or SimulatedHuman(delay=0, noise_std=0.1, epsilon=0.05)
    policy = policy or PolicySpec("tree")
    env = gym.make(env_id, **kwargs)
    datasets = [teleop_dataset]
    learner = fit(datasets, env, policy, seed)
    records = [
        DaggerIteration(
            0,
            tuple(datasets),
            len(load_pairs(datasets)[1]),
            0.0,
            **evaluate(learner, env, eval_episodes, 10_000 + seed, max_steps),
        )
    ]
    for k in range(1, iterations + 1):
        # 1. the learner's rollouts, as collect writes them (supervisor labels, no states)
        trajectories = collect(
            env_id,
            rollouts,
            env_kwargs=kwargs,
            actor=ActorSpec("learner", policy=learner),
            seed=seed + 1000 * k,
            max_steps=max_steps,
            progress=False,
        )
        rollouts_id = f"{namespace}/learner-iter{k}-v0"
        export_minari(
            rollouts_id,
            trajectories,
            env_id=env_id,
            env_kwargs=kwargs,
            provenance="learner",
            overwrite=True,
            algorithm_name="fluids-bench retroactive DAgger: learner rollouts",
            description=f"iteration {k}: the learner's rollouts, labelled by the supervisor",
        )
        # 2. offline retroactive labels: states rebuilt from the dataset, labelled one by one
        source = minari.load_dataset(rollouts_id)
        episodes = load_episodes(source)
        session = Relabel(spec_of(source), episodes, rollouts_id, human=labeller, seed=seed + k)
        result = session.run()
        executed = [
            np.asarray(ep.infos["executed_action"][t + 1])
            for ep in episodes
            for t in range(len(ep))
        ]
        given = [
            np.asarray(result.labels[(e, t)][0])
            for e, ep in enumerate(episodes)
            for t in range(len(ep))
        ]
        changed = float(
            np.mean([not np.allclose(a, b) for a, b in zip(executed, given, strict=True)])
        )
        labelled_id = f"{namespace}/learner-iter{k}-v1"
        write_dataset(
            labelled_id,
            relabelled_episodes(episodes, result.labels, env.action_space),
            spec_of(source),
            session={"kind": "relabel", "who": labeller.describe(), "source": rollouts_id},
            overwrite=True,
            algorithm_name=f"retroactive labels by {labeller.describe()}",
            description=f"{rollouts_id} relabelled retroactively",
        )
        # 3. aggregate and refit
        datasets.append(labelled_id)
        learner = fit(datasets, env, policy, seed)
        records.append(
            DaggerIteration(
                k,
                tuple(datasets),
                len(load_pairs(datasets)[1]),
                changed,
                **evaluate(learner, env, eval_episodes, 10_000 + seed, max_steps),
            )
        )
    env.close()
    return records
