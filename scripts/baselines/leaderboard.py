"""The leaderboard's scorecards: train every imitation baseline on every task of the suite, then
evaluate it on the suite's test and OOD sets (`fluids_bench.benchmark.evaluate`, what
`fluids-bench evaluate` runs), writing `docs/results/scorecard_<name>.json`.

    nice -n 15 python scripts/baselines/leaderboard.py --baselines references bc dagger dart \\
        --out runs/evaluate --train-out runs/train --workers 1

`references` evaluates the random policy and the supervisor (every learner's scorecard needs
their episodes; they are shared through `--out`). Each learner baseline is one algorithm of
`fluids-bench train` with the decision-tree learner, trained on train seeds only (the harness
draws them below 2**31 - 1; `seed` picks them), with the budget of `BUDGET`: per task the same
number of supervisor-labelled rollouts and the same cap on labels kept per rollout for every
algorithm (DAgger's and SHIV's initial demonstration counts as one of the rollouts), so every
learner gets the same label budget per task (SHIV queries a subset of it; DART also estimates
its noise from the labelled pairs the cap leaves over). Each run is exactly the `fluids-bench
train` command `train_command` prints (a test checks the two configs agree); its result JSON
goes to `TRAIN_OUT/<name>/`.

Resumable and idempotent: a task whose train result is complete (same config) is not trained
again, an evaluation runs only the episodes missing from `OUT/episodes/` (a train result's
learner is rebuilt only if some are missing), and a baseline whose scorecard is up to date (same
suite, same train results) is skipped. `--episodes N` and `--tasks` run a shortened suite
and `--test-only` the test split alone (each labelled so in the scorecards; `--suffix` keeps
their files apart from the full suite's). The CI test runs GridWorld with 2 episodes per set.

`ppo` is the RL baseline: stable-baselines3 PPO with its defaults (`rl_baselines.py`'s
recipe: 2 envs, one torch thread) trained on each task's reward for `RL_BUDGET`'s env steps by
`rl_baselines.train_run` (resumable), in `rl_baselines.py`'s layout
`RL_WORK/<env id>/<kwargs JSON>/ppo_s<seed>/model.zip` (`RL_WORK` is `TRAIN_OUT/ppo` unless
`--rl-work` names another), then evaluated from that `.zip` like any SB3 model. A finished run
found there with at least the budget's steps is evaluated without training again, so a run of
`rl_baselines.py --algos ppo --seeds 0 --steps <budget> --work DIR` is reused with
`--rl-work DIR` (once it has finished: a run still training there must not be resumed twice):

    python scripts/baselines/leaderboard.py --baselines ppo --tasks fluids --test-only \\
        --suffix _fluids_test --rl-work ../runs/rl_v4 --out runs/evaluate --workers 1

Its scorecards are `scorecard_ppo<suffix>.json` (`ppo_seed<s>` for other seeds).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import importlib.util
import json
import shlex
import shutil
import sys
from pathlib import Path
from typing import Any, NamedTuple

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.registry import get_algorithm
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.benchmark.evaluator import evaluate
from fluids_bench.benchmark.policies import PolicySource, train_result_source
from fluids_bench.benchmark.suite import SUITE, TASK_NAMES, Suite, Task
from fluids_bench.core.provenance import relative_paths
from fluids_bench.core.splits import refuse_test_seeds

ROOT = Path(__file__).resolve().parents[2]
LEARNER = "tree"  # the scikit-learn decision tree (`--policy tree`), the source's learner


class Budget(NamedTuple):
    """One task's training budget, the same for every algorithm.

    Attributes:
        rollouts: supervisor-labelled rollouts per run (demonstrations for BC, noise and DART;
            the initial demonstration plus on-policy rollouts for DAgger, DAgger-B and SHIV).
        samples: labels kept per rollout (`--samples-per-demo`): at most `rollouts * samples`
            training labels per run.
        eval_episodes: episodes (train seeds) of each learning-curve point, at a quarter, half
            and all of the rollouts.
    """

    rollouts: int
    samples: int
    eval_episodes: int = 5


# Per task. Horizons: FLUIDS-v4 600 steps (the supervisor's episodes last 77 to 340),
# GridWorld 30, Singulation 150, grasping and the track 600, MuJoCo 1,000.
BUDGET: dict[str, Budget] = {
    "fluids": Budget(30, 75),
    "gridworld": Budget(20, 30),
    "singulation": Budget(20, 50),
    "grasping": Budget(20, 50),
    "track": Budget(20, 50),
    "hopper": Budget(20, 100),
    "walker2d": Budget(20, 100),
    "halfcheetah": Budget(20, 100),
    "humanoid": Budget(20, 100),
}


class Baseline(NamedTuple):
    """One learner baseline: a `fluids-bench train` algorithm and its options.

    Attributes:
        algo: the algorithm (`--algo`).
        options: its options beyond the budget (config field -> value).
        initial_demos: rollouts it starts with (iteration 0), counted in the budget.
        about: what it is, in words (for the docs).
    """

    algo: str
    options: dict[str, Any]
    initial_demos: int
    about: str


BASELINES: dict[str, Baseline] = {
    "bc": Baseline("bc", {}, 0, "behaviour cloning on supervisor demonstrations"),
    "dagger": Baseline(
        "dagger", {"initial_demos": 1}, 1, "DAgger: on-policy rollouts, refit every iteration"
    ),
    "dagger_b": Baseline(
        "dagger_b",
        {"initial_demos": 1, "retrain_every": 5},
        1,
        "DAgger-B: on-policy rollouts, refit every 5 iterations",
    ),
    "noise": Baseline(
        "noise",
        {"noise_std": 0.1, "epsilon": 0.1},
        0,
        "demonstrations under isotropic noise (std 0.1 on Box actions, a random action with "
        "probability 0.1 on Discrete ones)",
    ),
    "dart": Baseline(
        "dart",
        {"update_every": 5},
        0,
        "DART: demonstrations under noise fit to the learner's errors, refit every 5 rollouts "
        "(the estimated magnitude, no alpha)",
    ),
    "shiv": Baseline(
        "shiv",
        {"initial_demos": 1},
        1,
        "SHIV: on-policy rollouts, labels queried only in risky states",
    ),
}
REFERENCES = ("random", "supervisor")


class RLBudget(NamedTuple):
    """One task's budget for the `ppo` baseline (`rl_baselines.train_run`'s settings).

    Attributes:
        steps: env steps of training (SB3 stops at the end of the rollout that reaches them:
            PPO's rollouts are 2,048 steps per env).
        eval_every: env steps between learning-curve points.
        eval_episodes: episodes (train seeds 100,000 + i) of each curve point.
        n_envs: envs of the `DummyVecEnv` (seeded `seed`, `seed + 1`, ...).
    """

    steps: int
    eval_every: int
    eval_episodes: int = 20
    n_envs: int = 2


RL_ALGO = "ppo"  # PPO on every task, Box and Discrete actions alike, SB3's defaults
# Per task. FLUIDS-v4: 200k steps, about 18 CPU-minutes at its trajectory level (the first 100k
# took 546 CPU-s with PPO's updates; more did not fit one session on 2 shared cores); GridWorld and MuJoCo as their
# rl_baselines results (docs/results/rl_gridworld.json, rl_hopper.json, ...); Singulation and
# grasping 200k (their rl_*.json ran 15k); the track 50k (its HOG observation makes a step cost
# about 5 ms).
RL_BUDGET: dict[str, RLBudget] = {
    "fluids": RLBudget(200_000, 100_000),
    "gridworld": RLBudget(50_000, 10_000),
    "singulation": RLBudget(200_000, 50_000),
    "grasping": RLBudget(200_000, 50_000),
    "track": RLBudget(50_000, 25_000),
    "hopper": RLBudget(200_000, 50_000),
    "walker2d": RLBudget(200_000, 50_000),
    "halfcheetah": RLBudget(200_000, 50_000),
    "humanoid": RLBudget(200_000, 50_000),
}
PPO_ROLLOUT = 2048  # SB3 PPO's n_steps per env: a run ends up to one rollout past its budget
CHOICES = ("references", *BASELINES, RL_ALGO)


def policy_name(baseline: str, seed: int) -> str:
    """The scorecard's policy name: `<baseline>_tree`, `_seed<s>` for seeds other than 0."""
    return f"{baseline}_{LEARNER}" + ("" if seed == 0 else f"_seed{seed}")


def train_settings(baseline: str, task: Task, seed: int) -> dict[str, Any]:
    """The config fields of `baseline`'s run on `task` (budget, options, seed)."""
    spec, budget = BASELINES[baseline], BUDGET[task.name]
    iterations = budget.rollouts - spec.initial_demos
    points = sorted({budget.rollouts // 4, budget.rollouts // 2})
    return {
        **spec.options,
        "env_id": task.env_id,
        "env_kwargs": dict(task.env_kwargs),
        "iterations": iterations,
        "demos_per_iteration": 1,
        "samples_per_demo": budget.samples,
        "eval_episodes": budget.eval_episodes,
        "eval_at": tuple(p - spec.initial_demos for p in points if p > spec.initial_demos),
        "seed": seed,
    }


def train_config(baseline: str, task: Task, seed: int) -> Any:
    from fluids_bench.algos.learners.sklearn import PolicySpec

    algorithm = get_algorithm(BASELINES[baseline].algo)
    settings = {**algorithm.presets, **train_settings(baseline, task, seed)}
    return algorithm.config_class(**settings, policy=PolicySpec(LEARNER))


def train_command(baseline: str, task: Task, seed: int, out: str) -> list[str]:
    """The `fluids-bench train` command of the same run (arguments after `fluids-bench`)."""
    from fluids_bench.commands.train import ALGO_OPTIONS

    settings = train_settings(baseline, task, seed)
    option_of = {dest: option for option, (dest, _, _) in ALGO_OPTIONS.items()}
    args = ["train", "--env", task.env_id, "--algo", BASELINES[baseline].algo]
    args += ["--policy", LEARNER]
    for key, value in settings["env_kwargs"].items():
        args += ["--env-kwarg", f"{key}={json.dumps(value)}"]
    args += ["--iterations", str(settings["iterations"]), "--samples-per-demo"]
    args += [str(settings["samples_per_demo"]), "--eval-episodes"]
    args += [str(settings["eval_episodes"]), "--seed", str(seed), "--out", out]
    if settings["eval_at"]:
        args += ["--eval-at", *map(str, settings["eval_at"])]
    for key, value in BASELINES[baseline].options.items():
        args += [option_of[key], *(map(str, value) if isinstance(value, tuple) else [str(value)])]
    return args


def _same_config(path: Path, algo: str, config: Any) -> bool:
    saved = json.loads(path.read_text())
    wanted = json.loads(json.dumps(config.to_dict()))
    return saved.get("algo") == algo and saved.get("config") == wanted


def train(baseline: str, task: Task, seed: int, train_out: Path, progress: bool) -> Any:
    """Train `baseline` on `task` unless its complete result is there; the source to evaluate."""
    from tqdm import tqdm

    algo = BASELINES[baseline].algo
    config = train_config(baseline, task, seed)
    folder = train_out / policy_name(baseline, seed)
    stem = f"{algo}_{config.env_id}_seed{seed}"
    path, checkpoint = folder / f"{stem}.json", folder / f"{stem}.checkpoint"
    name = policy_name(baseline, seed)
    if path.is_file() and _same_config(path, algo, config):
        if json.loads(path.read_text()).get("complete"):
            return train_result_source(path, name)  # the learner is rebuilt only if needed
    folder.mkdir(parents=True, exist_ok=True)
    run_config = dataclasses.replace(config, checkpoint=str(checkpoint))
    finished: list[Any] = []
    total = config.iterations + BASELINES[baseline].initial_demos
    with tqdm(total=total, desc=f"{algo} on {task.name}", disable=not progress) as bar:

        def record(rec: Any) -> None:  # as `fluids-bench train` does: each iteration kept
            bar.update(1)
            finished.append(rec)
            write_json_atomic(
                path,
                {
                    "algo": algo,
                    "config": config.to_dict(),
                    "records": [dataclasses.asdict(r) for r in finished],
                    "complete": False,
                },
            )

        result = get_algorithm(algo).run(run_config, record)
    write_json_atomic(path, {**result.to_dict(), "complete": True})
    shutil.rmtree(checkpoint, ignore_errors=True)
    return train_result_source(path, name, result)


def _normalised(data: Any) -> Any:
    return json.loads(json.dumps(data))


def up_to_date(path: Path, suite: Suite, train_results: dict[str, Path] | None) -> bool:
    """Whether the scorecard at `path` is of this suite and (learners) these train results."""
    if not path.is_file():
        return False
    card = json.loads(path.read_text())
    if card.get("suite") != _normalised(suite.to_dict()):
        return False
    if train_results is None:
        return True
    policy = card.get("policy", {})
    if policy.get("kind") == "per_task":
        tasks = policy.get("tasks")
    else:  # one task: the scorecard holds its source alone
        tasks = {task: policy for task in train_results} if len(train_results) == 1 else None
    if tasks is None or set(tasks) != set(train_results):
        return False
    for task, result in train_results.items():
        if tasks[task].get("train_result") != str(result) or not result.is_file():
            return False
        if not json.loads(result.read_text()).get("complete"):
            return False
    return True


def _shown(path: Path) -> Path:
    return Path(relative_paths([str(path)])[0])


def rl_name(seed: int) -> str:
    """The `ppo` baseline's scorecard policy name: `ppo`, `ppo_seed<s>` for seeds other than 0."""
    return RL_ALGO + ("" if seed == 0 else f"_seed{seed}")


def rl_work(root: Path, task: Task, seed: int) -> Path:
    """A run's folder, as `rl_baselines.py --work ROOT` lays it out."""
    return root / task.env_id / json.dumps(dict(task.env_kwargs), sort_keys=True) / f"ppo_s{seed}"


def _rl_baselines() -> Any:
    path = Path(__file__).resolve().parent / "rl_baselines.py"
    spec = importlib.util.spec_from_file_location("rl_baselines", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _trained_steps(work: Path) -> int:
    """Env steps of the run in `work` at its last checkpoint (0 without one)."""
    curve_file, model = work / "curve.json", work / "model.zip"
    if not (curve_file.is_file() and model.is_file()):
        return 0
    curve = json.loads(curve_file.read_text())
    return int(curve[-1]["steps"]) if curve else 0


def train_rl(task: Task, seed: int, root: Path, progress: bool) -> Path:
    """Train PPO on `task` with its `RL_BUDGET` unless a finished run is in its folder under
    `root`; the model file. A run of more steps than the budget (past one rollout) is refused."""
    from tqdm import tqdm

    budget = RL_BUDGET[task.name]
    refuse_test_seeds(range(seed, seed + budget.n_envs), "leaderboard.py --baselines ppo")
    work = rl_work(root, task, seed)
    done = _trained_steps(work)
    if done > budget.steps + PPO_ROLLOUT * budget.n_envs:
        raise ValueError(
            f"{work} holds a PPO run of {done:,} env steps, more than {task.name}'s budget of "
            f"{budget.steps:,} (RL_BUDGET); use another --rl-work"
        )
    if done < budget.steps:
        rl = _rl_baselines()
        rl._torch_on_one_thread()
        with tqdm(total=budget.steps, desc=f"ppo on {task.name}", disable=not progress) as bar:
            rl.train_run(
                RL_ALGO, task.env_id, dict(task.env_kwargs), seed, budget.steps,
                budget.eval_every, budget.eval_episodes, budget.n_envs, work, bar,
            )  # fmt: skip
    return work / "model.zip"


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def rl_source(task: Task, seed: int, model: Path, name: str) -> PolicySource:
    """The SB3 model `model` (PPO trained on `task`) as the evaluator's policy, with what the
    scorecard records of its run: env, seed, env steps, budget and the model file's hash."""
    budget = RL_BUDGET[task.name]
    extras = {
        "algo": RL_ALGO,
        "env_id": task.env_id,
        "env_kwargs": dict(task.env_kwargs),
        "train_seed": seed,
        "labels_used": 0,  # PPO learns from the reward, never from a supervisor label
        "env_steps": _trained_steps(model.parent),
        "budget_steps": budget.steps,
        "n_envs": budget.n_envs,
        "model_sha256": _sha256(model),
    }
    return PolicySource(name, "sb3", str(_shown(model)), None, extras)


def _policy_entries(card: dict, tasks: list[str]) -> dict[str, dict] | None:
    policy = card.get("policy", {})
    if policy.get("kind") == "per_task":
        return policy.get("tasks")
    return {tasks[0]: policy} if len(tasks) == 1 else None


def rl_up_to_date(path: Path, suite: Suite, sources: dict[str, PolicySource]) -> bool:
    """Whether the scorecard at `path` is of this suite and these model files (by hash)."""
    if not path.is_file():
        return False
    card = json.loads(path.read_text())
    if card.get("suite") != _normalised(suite.to_dict()):
        return False
    entries = _policy_entries(card, list(sources))
    if entries is None or set(entries) != set(sources):
        return False
    return all(
        entries[task].get("model_sha256") == source.extras["model_sha256"]
        and entries[task].get("spec") == source.spec
        for task, source in sources.items()
    )


def run_rl(suite: Suite, args: argparse.Namespace, command: str) -> None:
    """The `ppo` baseline: train (or find) each task's model, then evaluate them on `suite`."""
    root = args.rl_work if args.rl_work is not None else args.train_out / RL_ALGO
    for seed in args.seeds:
        name = rl_name(seed)
        card = args.results / f"scorecard_{name}{args.suffix}.json"
        sources = {}
        for task in suite.tasks:
            model = train_rl(task, seed, root, not args.no_progress)
            sources[task.name] = rl_source(task, seed, model, name)
        if rl_up_to_date(card, suite, sources):
            print(f"{name}: {card} is up to date")
            continue
        evaluate_card(sources, name, card, suite, args, command)


def evaluate_card(
    sources: Any, name: str, card: Path, suite: Suite, args: argparse.Namespace, command: str
) -> None:
    """Evaluate `sources` (a policy per task) as `name` on `suite`, writing `card`."""
    evaluate(
        sources, suite, args.out, name=name, workers=args.workers,
        progress=not args.no_progress, plots=not args.no_plots, scorecard=card, command=command,
    )  # fmt: skip
    print(f"{name}: wrote {card}")


def run_baseline(baseline: str, suite: Suite, args: argparse.Namespace, command: str) -> None:
    if baseline == RL_ALGO:
        return run_rl(suite, args, command)
    if baseline == "references":
        for ref in REFERENCES:
            card = args.results / f"scorecard_{ref}{args.suffix}.json"
            if up_to_date(card, suite, None):
                print(f"{ref}: {card} is up to date")
                continue
            evaluate(
                ref, suite, args.out, workers=args.workers, progress=not args.no_progress,
                plots=not args.no_plots, scorecard=card, command=command,
            )  # fmt: skip
            print(f"{ref}: wrote {card}")
        return
    for seed in args.seeds:
        name = policy_name(baseline, seed)
        card = args.results / f"scorecard_{name}{args.suffix}.json"
        algo = BASELINES[baseline].algo
        paths = {
            t.name: _shown(args.train_out / name / f"{algo}_{t.env_id}_seed{seed}.json")
            for t in suite.tasks
        }
        if up_to_date(card, suite, paths):
            print(f"{name}: {card} is up to date")
            continue
        sources = {}
        for task in suite.tasks:
            sources[task.name] = train(baseline, task, seed, args.train_out, not args.no_progress)
            sources[task.name].spec = sources[task.name].extras["train_result"] = str(
                paths[task.name]
            )
        evaluate_card(sources, name, card, suite, args, command)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--baselines", nargs="+", default=list(CHOICES), choices=CHOICES,
        help="what to run, in order (default: all)",
    )  # fmt: skip
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="training seeds")
    parser.add_argument("--tasks", nargs="+", default=None, choices=TASK_NAMES)
    parser.add_argument(
        "--episodes", type=int, default=None, help="the first N episodes of each set (shortened)"
    )
    parser.add_argument(
        "--test-only", action="store_true", help="the test split alone, no OOD sets (shortened)"
    )
    parser.add_argument(
        "--suffix", default="", help="scorecard files are scorecard_<name><suffix>.json"
    )
    parser.add_argument("--out", type=Path, default=Path("runs/evaluate"))
    parser.add_argument("--train-out", type=Path, default=Path("runs/train"))
    parser.add_argument(
        "--rl-work", type=Path, default=None,
        help="ppo: the runs' folder, laid out as rl_baselines.py --work (default TRAIN_OUT/ppo); "
        "a finished run there with the budget's steps is evaluated, not trained again",
    )  # fmt: skip
    parser.add_argument("--results", type=Path, default=ROOT / "docs" / "results")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--no-progress", action="store_true")
    parser.add_argument("--no-plots", action="store_true")
    args = parser.parse_args(argv)
    suite = SUITE.select(args.episodes, args.tasks, ood=not args.test_only)
    argv = sys.argv[1:] if argv is None else argv
    command = " ".join(
        ["python", "scripts/baselines/leaderboard.py", *map(shlex.quote, relative_paths(argv))]
    )
    for baseline in args.baselines:
        run_baseline(baseline, suite, args, command)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
