"""The benchmark page's tables, from the code (`fluids_bench.benchmark`), and the leaderboard,
from the scorecards in `docs/results/scorecard_*.json` (written by `fluids-bench evaluate`)."""

from __future__ import annotations

import json
from pathlib import Path

RESULTS = Path(__file__).resolve().parents[1] / "results"


def _kwargs(kwargs: dict) -> str:
    return ", ".join(f"`{k}={json.dumps(v)}`" for k, v in kwargs.items()) or "(defaults)"


def benchmark_definition() -> str:
    """One row per task: id, kwargs, action level, observation, splits, OOD sets."""
    from fluids_bench.benchmark.suite import SUITE

    rows = [
        "| task | id and kwargs | the learner acts | it observes | validation / test episodes "
        "| out-of-distribution test sets (episodes) |",
        "|---|---|---|---|---|---|",
    ]
    for t in SUITE.tasks:
        ood = "<br>".join(
            f"`{o.name}`: {o.description} ({_kwargs(dict(o.kwargs))}; {o.episodes})" for o in t.ood
        )
        rows.append(
            f"| {t.name} | `{t.env_id}` {_kwargs(dict(t.env_kwargs))} | {t.action_level} | "
            f"{t.observation} | {t.validation_episodes} / {t.test_episodes} | {ood} |"
        )
    return "\n".join(rows)


def benchmark_fluids_id() -> str:
    """The suite's FLUIDS id."""
    from fluids_bench.benchmark.suite import FLUIDS_ID

    return FLUIDS_ID


def seed_splits() -> str:
    """The seed ranges of the splits."""
    from fluids_bench.core import splits

    return "\n".join(
        [
            "| split | seeds | used by |",
            "|---|---|---|",
            f"| train | 0 to {splits.TRAIN_END - 1:,} | `collect --seed`, `train` and the "
            "algorithm harness (its draws stay below this bound) |",
            f"| validation | {splits.VALIDATION_START:,} + i | model selection; never reported |",
            f"| test | {splits.TEST_START:,} + i | `fluids-bench evaluate`'s test split |",
            f"| out-of-distribution | {splits.OOD_START:,} + i | `evaluate`'s OOD sets |",
        ]
    )


def _triple(t: list[float] | None, digits: int = 2) -> str:
    if not t:
        return "n/a"
    return f"{t[0]:.{digits}f} [{t[1]:.{digits}f}, {t[2]:.{digits}f}]"


def scorecards() -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(RESULTS.glob("scorecard_*.json"))]


def leaderboard() -> str:
    """Every scorecard: the suite's mean and IQM of the normalised score, test and OOD, with
    stratified-bootstrap 95 % intervals, its episodes and tasks, and its command."""
    cards = scorecards()
    if not cards:
        return "*No scorecards in `docs/results/` yet.*"
    order = {"supervisor": 0, "random": 2}
    cards.sort(key=lambda c: (order.get(c["policy"]["name"], 1), c["policy"]["name"]))
    rows = [
        "| policy | tasks | episodes per set | test: mean | test: IQM | OOD: mean | OOD: IQM |",
        "|---|---|---|---|---|---|---|",
    ]
    for card in cards:
        test, ood = card["aggregate"].get("test") or {}, card["aggregate"].get("ood") or {}
        episodes = card["episodes_per_set"] or "all"
        label = f"{episodes} (shortened)" if card["shortened"] else f"{episodes}"
        if not any(t["ood"] for t in card["suite"]["tasks"]):
            label += ", test split only"
        rows.append(
            f"| {card['policy']['name']} | {', '.join(card['tasks'])} | {label} | "
            f"{_triple(test.get('mean'))} | {_triple(test.get('iqm'))} | "
            f"{_triple(ood.get('mean'))} | {_triple(ood.get('iqm'))} |"
        )
    rows.append("")
    rows.append("Commands:")
    rows.append("")
    for card in cards:
        rows.append(f"- {card['policy']['name']}: `{card['provenance']['command']}` "
                    f"(revision `{card['provenance']['git_revision']}`)")  # fmt: skip
    return "\n".join(rows)


def leaderboard_budget() -> str:
    """The leaderboard driver's training budget per task and its baselines, from
    `scripts/baselines/leaderboard.py` (`BUDGET`, `BASELINES`, and PPO's `RL_BUDGET`)."""
    import importlib.util

    path = Path(__file__).resolve().parents[2] / "scripts" / "baselines" / "leaderboard.py"
    spec = importlib.util.spec_from_file_location("leaderboard_driver", path)
    driver = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(driver)
    rows = [
        "| task | rollouts per run | labels kept per rollout | training labels at most | "
        "evaluation episodes per curve point |",
        "|---|---|---|---|---|",
    ]
    for task, b in driver.BUDGET.items():
        rows.append(
            f"| {task} | {b.rollouts} | {b.samples} | {b.rollouts * b.samples:,} | "
            f"{b.eval_episodes} |"
        )
    rows += ["", "| baseline | `--algo` | what it is |", "|---|---|---|"]
    for name, spec_ in driver.BASELINES.items():
        rows.append(f"| `{driver.policy_name(name, 0)}` | `{spec_.algo}` | {spec_.about} |")
    rows += [
        "",
        f"The RL baseline `{driver.rl_name(0)}` (`--baselines {driver.RL_ALGO}`): "
        "stable-baselines3 PPO with its default hyperparameters on every task, trained on the "
        "task's reward (no supervisor label), in a `DummyVecEnv` of the stated envs, then "
        "evaluated from its model file; the learning curve is evaluated on train seeds "
        "100,000 + i:",
        "",
        "| task | env steps | envs | curve point every | episodes per curve point |",
        "|---|---|---|---|---|",
    ]
    for task, b in driver.RL_BUDGET.items():
        rows.append(
            f"| {task} | {b.steps:,} | {b.n_envs} | {b.eval_every:,} steps | {b.eval_episodes} |"
        )
    return "\n".join(rows)
