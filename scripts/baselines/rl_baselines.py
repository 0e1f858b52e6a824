"""Off-the-shelf RL baselines (stable-baselines3, CPU torch): learning curves and final success.

Trains SB3 PPO (and SAC on continuous actions, DQN on discrete ones) with SB3's default
hyperparameters on one registered id, several seeds, and writes the learning curves (success
rate and mean return against env steps and CPU time) to ``--out`` (JSON) and ``--image`` (PNG).
Every run uses a ``DummyVecEnv`` of ``--n-envs`` copies of the env (one process, torch on one
thread), SB3's defaults otherwise (PPO: n_steps 2048, batch 64, 10 epochs, lr 3e-4, gamma 0.99,
gae_lambda 0.95, clip 0.2, a 64x64 tanh MLP for policy and value). Training seed ``s`` seeds
torch, the policy's sampling and the envs (``s``, ``s + 1``, ...; SB3's ``make_vec_env``).

Evaluation: the deterministic policy (the Gaussian's mean, DQN's greedy action) on episodes
seeded ``EVAL_SEED + i`` (100000 + i, never used in training): every ``--eval-every`` steps on
``--eval-episodes`` episodes (the curve), and at the end on ``--final-episodes``. The random
policy (``action_space.sample()``, seeded per episode) and the supervisor are evaluated on the
same final episodes.

Resumable: each (algo, seed) run checkpoints its model and curve under ``--work`` at every
evaluation; a rerun continues from the last checkpoint (SB3 restores the step count; a resumed
run is not bit-identical to an uninterrupted one) and skips finished runs.

``--ablation`` instead runs the FLUIDS action / reward / observation ablation: PPO on
``FLUIDS-v1`` at the velocity level with each of the v2 options switched on alone and together
(one seed, ``--steps`` each), evaluated on ``--final-episodes`` episodes; written to ``--out``.

    python scripts/baselines/rl_baselines.py --env FLUIDS-v2 --env-kwargs '{"action_level": "velocity"}' \\
        --steps 200000 --seeds 0 1 2 --final-episodes 200 \\
        --out docs/results/rl_fluids_v2.json --image docs/images/rl_fluids_v2.png
    python scripts/baselines/rl_baselines.py --ablation --steps 100000 --final-episodes 100 \\
        --out docs/results/fluids_ppo_ablation.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import fluids_bench  # noqa: F401  (registers the ids)
from fluids_bench.algos.results import write_json_atomic
from fluids_bench.core.provenance import relative_paths

EVAL_SEED = 100_000

# The ablation: FLUIDS-v1 at the velocity level, each v2 option alone and together.
ABLATION_BASE = ("FLUIDS-v1", {"action_level": "velocity"})
ABLATION_ARMS = {
    "v1 (physical units)": {},
    "normalised actions": {"action_scale": "normalized"},
    "reward v1": {"reward_version": 1},
    "normalised observations": {"obs_scale": "normalized"},
    "all three (FLUIDS-v2)": {
        "action_scale": "normalized",
        "reward_version": 1,
        "obs_scale": "normalized",
    },
}


def algos_for(space: gym.Space) -> list[str]:
    """PPO everywhere; SAC on Box actions, DQN on Discrete ones."""
    return ["ppo", "sac"] if isinstance(space, gym.spaces.Box) else ["ppo", "dqn"]


def evaluate(env_id: str, kwargs: dict, act, episodes: int) -> dict:
    """Success rate, mean return and length over seeded episodes; FLUIDS' failure modes
    (collisions, red-light runs, failures to yield, timeouts) where its info has them."""
    env = gym.make(env_id, **kwargs)
    out = {"episodes": episodes, "success": 0, "returns": [], "lengths": [], "actions": []}
    fluids = {"collision": 0, "red_light_runs": 0, "failed_to_yield": 0, "timeouts": 0}
    has_success = False  # tasks without is_success (GridWorld) are compared by return
    for i in range(episodes):
        seed = EVAL_SEED + i
        env.action_space.seed(seed)
        obs, info = env.reset(seed=seed)
        ret, steps, hit = 0.0, 0, False
        while True:
            action = act(obs, env)
            out["actions"].append(_physical(env, action))
            obs, reward, term, trunc, info = env.step(action)
            ret += float(reward)
            steps += 1
            hit = hit or bool(info.get("collisions"))
            if term or trunc:
                break
        out["success"] += bool(info.get("is_success", False))
        has_success = has_success or "is_success" in info
        out["returns"].append(ret)
        out["lengths"].append(steps)
        if "ego_ran_red_light" in info:
            fluids["collision"] += hit
            fluids["red_light_runs"] += bool(info["ego_ran_red_light"])
            fluids["failed_to_yield"] += bool(info["ego_failed_to_yield"])
            fluids["timeouts"] += bool(trunc and not term)
    env.close()
    actions = np.concatenate(out.pop("actions"))
    returns, lengths = out.pop("returns"), out.pop("lengths")
    out.update(
        success_rate=out["success"] / episodes,
        mean_return=round(float(np.mean(returns)), 4),
        mean_length=round(float(np.mean(lengths)), 1),
        mean_first_action=round(float(actions.mean()), 4),
        metric="success_rate" if has_success else "mean_return",
    )
    if "ego_ran_red_light" in info:
        out.update(fluids)
    return out


def _physical(env: gym.Env, action) -> np.ndarray:
    """The action's first entry, at FLUIDS' velocity level as the target speed in m/s."""
    a = np.asarray(action, dtype=np.float64).reshape(-1)[:1]
    u = env.unwrapped
    if getattr(u, "action_level", None) == "velocity":
        from fluids_bench.tasks.fluids.core import actions

        space = env.action_space
        a = np.clip(a, space.low, space.high)
        if u.action_scale == "normalized":
            a = actions.to_physical("velocity", u.world, a)
    return a


def _vec_env(env_id: str, kwargs: dict, n_envs: int, seed: int):
    """SB3's ``make_vec_env``, with ``render_mode=None`` (SB3 asks for "rgb_array" unless told;
    training envs are never drawn, and a renderer costs set-up). "fluids_bench:<id>" imports
    the package wherever the env is built."""
    from stable_baselines3.common.env_util import make_vec_env

    return make_vec_env(
        f"fluids_bench:{env_id}", n_envs=n_envs, seed=seed,
        env_kwargs={"render_mode": None, **kwargs},
    )  # fmt: skip


def _model(algo: str, venv, seed: int, algo_kwargs: dict | None = None):
    from stable_baselines3 import DQN, PPO, SAC

    cls = {"ppo": PPO, "sac": SAC, "dqn": DQN}[algo]
    extra = (algo_kwargs or {}).get(algo, {})
    return cls("MlpPolicy", venv, seed=seed, verbose=0, device="cpu", **extra)


def _algo_kwargs(text: str) -> dict:
    """``--algo-kwargs``: a JSON object from algorithm name to keyword arguments of its class."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as err:
        raise ValueError(f"--algo-kwargs must be JSON, got {text!r}: {err}") from None
    if not isinstance(value, dict) or not all(
        k in ("ppo", "sac", "dqn") and isinstance(v, dict) for k, v in value.items()
    ):
        raise ValueError(
            '--algo-kwargs must map "ppo", "sac" or "dqn" to an object of keyword arguments, '
            f"got {text!r}"
        )
    return value


def _policy(model):
    return lambda obs, env: model.predict(obs, deterministic=True)[0]


def _random(obs, env):
    return env.action_space.sample()


def _supervisor(obs, env):
    return env.unwrapped.supervisor_action()


def train_run(
    algo: str,
    env_id: str,
    kwargs: dict,
    seed: int,
    steps: int,
    eval_every: int,
    eval_episodes: int,
    n_envs: int,
    work: Path,
    bar: tqdm,
    algo_kwargs: dict | None = None,
):
    """One (algo, seed) run with its curve, resumed from ``work`` where it stopped.

    One ``learn`` call up to ``steps`` (not one per curve point), so SB3's schedules (DQN's
    exploration rate) span the whole run, a resumed one included. The curve points are taken
    between rollouts, once ``eval_every`` steps have passed since the last one, and at the end.
    """
    from stable_baselines3.common.callbacks import BaseCallback

    work.mkdir(parents=True, exist_ok=True)
    ckpt, curve_file = work / "model.zip", work / "curve.json"
    venv = _vec_env(env_id, kwargs, n_envs, seed)
    curve = json.loads(curve_file.read_text()) if curve_file.is_file() else []
    if ckpt.is_file() and curve:
        cls = type(_model(algo, venv, seed, algo_kwargs))
        model = cls.load(ckpt, env=venv, device="cpu")
    else:
        model, curve = _model(algo, venv, seed, algo_kwargs), []
    bar.update(model.num_timesteps)
    clock = {"cpu": curve[-1]["train_cpu_s"] if curve else 0.0, "since": time.process_time()}
    clock["shown"] = model.num_timesteps

    def add_point() -> None:
        """Evaluate now (its CPU time is not training time) and checkpoint."""
        clock["cpu"] += time.process_time() - clock["since"]
        bar.update(model.num_timesteps - clock["shown"])
        clock["shown"] = model.num_timesteps
        point = evaluate(env_id, kwargs, _policy(model), eval_episodes)
        curve.append(
            {"steps": int(model.num_timesteps), "train_cpu_s": round(clock["cpu"], 1), **point}
        )
        model.save(ckpt)
        write_json_atomic(curve_file, curve)
        clock["since"] = time.process_time()

    class CurvePoints(BaseCallback):
        def _on_rollout_start(self) -> None:
            last = curve[-1]["steps"] if curve else 0
            if self.num_timesteps - last >= eval_every:
                add_point()

        def _on_step(self) -> bool:
            return True

    if model.num_timesteps < steps:
        model.learn(
            total_timesteps=steps - model.num_timesteps,
            reset_num_timesteps=False,
            callback=CurvePoints(),
        )
    if not curve or curve[-1]["steps"] < model.num_timesteps:
        add_point()
    return model, curve


def _torch_on_one_thread() -> None:
    """Import torch (the `train` extra) once the arguments are checked; one thread per run."""
    try:
        import stable_baselines3  # noqa: F401
        import torch
    except ImportError as e:
        raise ModuleNotFoundError(
            f"{e.name} is missing: training needs the train extra (torch, stable-baselines3): "
            'pip install torch==2.13.0 stable-baselines3  (or pip install "fluids-bench[train]")'
        ) from e
    torch.set_num_threads(1)


def configuration(args) -> dict:
    """What a curves run is: the env, its kwargs, the seeds and the settings recorded in the
    results file (tests check that a results file's command gives back its recorded ones)."""
    kwargs = json.loads(args.env_kwargs)
    algo_kwargs = _algo_kwargs(args.algo_kwargs)
    return {
        "env_id": args.env,
        "env_kwargs": kwargs,
        "seeds": args.seeds,
        "settings": {
            "steps": args.steps,
            "eval_every": args.eval_every,
            "eval_episodes": args.eval_episodes,
            "final_episodes": args.final_episodes,
            "eval_seeds": f"{EVAL_SEED} .. {EVAL_SEED + args.final_episodes - 1}",
            "n_envs": args.n_envs,
            "hyperparameters": "stable-baselines3 defaults (MlpPolicy), DummyVecEnv"
            + (f", except {json.dumps(algo_kwargs, sort_keys=True)}" if algo_kwargs else ""),
            "machine": "2-core CI-class machine, shared, torch CPU build on one thread",
        },
    }


def run_curves(args, command: str) -> None:
    kwargs = json.loads(args.env_kwargs)
    algo_kwargs = _algo_kwargs(args.algo_kwargs)
    _torch_on_one_thread()
    space = gym.make(args.env, **kwargs).action_space
    algos = args.algos or algos_for(space)
    print(
        f"expected run time: ~{len(algos) * len(args.seeds) * args.steps / 1000 * 1.2 / 60:.0f} min "
        "of CPU (PPO on FLUIDS ~1,000 steps per CPU-second; SAC several times slower) on 2 cores"
    )
    result = {"command": command, **configuration(args), "runs": []}
    env_work = Path(args.work) / args.env / json.dumps(kwargs, sort_keys=True)
    total = len(algos) * len(args.seeds) * args.steps
    with tqdm(total=total, unit="step", desc=args.env) as bar:
        for algo in algos:
            for seed in args.seeds:
                work = env_work / f"{algo}_s{seed}"
                final_file = work / "final.json"
                run = json.loads(final_file.read_text()) if final_file.is_file() else None
                if run is not None and run["curve"][-1]["steps"] < args.steps:
                    raise ValueError(
                        f"--steps {args.steps}: {final_file} holds a finished run of "
                        f"{run['curve'][-1]['steps']} steps; use another --work"
                    )
                if run is not None:
                    bar.update(args.steps)
                elif args.collect_only:  # the curve so far of a run still training elsewhere
                    curve_file = work / "curve.json"
                    curve = json.loads(curve_file.read_text()) if curve_file.is_file() else []
                    run = {"algo": algo, "seed": seed, "curve": curve, "final": None}
                else:
                    model, curve = train_run(
                        algo, args.env, kwargs, seed, args.steps, args.eval_every,
                        args.eval_episodes, args.n_envs, work, bar, algo_kwargs,
                    )  # fmt: skip
                    final = evaluate(args.env, kwargs, _policy(model), args.final_episodes)
                    run = {"algo": algo, "seed": seed, "curve": curve, "final": final}
                    write_json_atomic(final_file, run)
                result["runs"].append(run)
    # after training, cached under --work: processes that split the seeds evaluate them once
    for name, act in (("random", _random), ("supervisor", _supervisor)):
        result[name] = _cached_eval(env_work, name, args.env, kwargs, act, args.final_episodes)
    _write_curves(args, result, algos)


def refresh_references(args, command: str) -> None:
    """Re-evaluate the random and supervisor rows of a finished ``--out`` (e.g. after a new
    teacher is shipped) on its own final episodes, keeping its runs; redraw ``--image``."""
    path = Path(args.out)
    if not path.is_file():
        raise SystemExit(f"--references-only: --out {str(path)!r} is not a results file")
    result = json.loads(path.read_text())
    episodes = result["settings"]["final_episodes"]
    for name, act in (("random", _random), ("supervisor", _supervisor)):
        result[name] = evaluate(result["env_id"], result["env_kwargs"], act, episodes)
    result["references_from"] = command
    algos = sorted({r["algo"] for r in result["runs"]})
    args.seeds = result["seeds"]
    _write_curves(args, result, algos)


def _write_curves(args, result: dict, algos: list[str]) -> None:
    """The per-algorithm summary over seeds, written with the runs to --out (and --image)."""
    summary = {}
    metric = result["random"]["metric"]
    for algo in algos:
        values = [r["final"][metric] for r in result["runs"] if r["algo"] == algo and r["final"]]
        if len(values) < len(args.seeds):
            continue  # --collect-only with unfinished runs: no summary over fewer seeds
        summary[algo] = {
            "metric": metric,
            f"{metric}_mean": round(float(np.mean(values)), 4),
            f"{metric}_seeds": values,
            "beats_random_every_seed": all(v > result["random"][metric] for v in values),
        }
    result["summary"] = summary
    write_json_atomic(Path(args.out), result)
    if args.image:
        plot(result, Path(args.image))
    print(json.dumps({"random": result["random"][metric], **summary}, indent=1))


def _cached_eval(work: Path, name: str, env_id: str, kwargs: dict, act, episodes: int) -> dict:
    """A fixed policy's evaluation, computed once per episode count (and teacher: a shipped
    weight file's hash) and read back after."""
    tag = ""
    if name == "supervisor":
        record = gym.make(env_id, **kwargs).unwrapped.metadata.get("supervisor")
        teacher = record.get("weights_sha256") if isinstance(record, dict) else None
        tag = f"_{teacher[:12]}" if teacher else ""
    path = work / f"{name}_{episodes}_episodes{tag}.json"
    if path.is_file():
        return json.loads(path.read_text())
    out = evaluate(env_id, kwargs, act, episodes)
    write_json_atomic(path, out)
    return out


def plot(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=100)
    colours = {"ppo": "tab:blue", "sac": "tab:orange", "dqn": "tab:green"}
    s = result["settings"]
    for k, run in enumerate(result["runs"]):
        c = colours[run["algo"]]
        metric = result["random"].get("metric", "success_rate")
        xs = [p["steps"] for p in run["curve"]]
        ys = [p[metric] for p in run["curve"]]
        first = run["seed"] == result["seeds"][0]
        label = f"{run['algo'].upper()} curve ({s['eval_episodes']} episodes)" if first else None
        ax.plot(xs, ys, color=c, alpha=0.35, marker="o", ms=3, label=label)
        f = run["final"]
        if f is None:  # unfinished (--collect-only): its curve so far
            continue
        p = f[metric]
        se = (p * (1 - p) / f["episodes"]) ** 0.5 if metric == "success_rate" else 0.0
        label = f"{run['algo'].upper()} final ({f['episodes']} episodes)" if first else None
        ax.errorbar(xs[-1] * (1.01 + 0.015 * k), p, yerr=se, color=c, marker="s", ms=5,
                    capsize=3, ls="none", label=label)  # fmt: skip
    r = result["random"]
    metric = r.get("metric", "success_rate")
    p = r[metric]
    se = (p * (1 - p) / r["episodes"]) ** 0.5 if metric == "success_rate" else 0.0
    ax.axhline(p, color="grey", ls="--", label=f"random ({r['episodes']} episodes)")
    if se:
        ax.axhspan(p - se, p + se, color="grey", alpha=0.15)
    if "supervisor" in result:
        ax.axhline(result["supervisor"][metric], color="black", ls=":", label="supervisor")
    kw = json.dumps(result["env_kwargs"]) if result["env_kwargs"] else ""
    ax.set_title(f"{result['env_id']} {kw}", fontsize=9)
    ax.set_xlabel("env steps")
    if metric == "success_rate":
        ax.set_ylabel("success rate")
        ax.set_ylim(-0.02, 1.02)
    else:
        ax.set_ylabel("mean return")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)


def diagnose(episodes: int, seed: int, n_envs: int) -> dict:
    """Measurements behind the ablation, on ``FLUIDS-v1`` at the velocity level.

    * ``action``: what an untrained SB3 PPO policy (seed ``seed``) commands in its first
      rollout (2,048 steps per env, sampled as in training): the share of its Gaussian
      samples below the Box (clipped to 0 m/s with physical units) and the mean target speed
      after clipping, with physical and with normalised actions.
    * ``reward``: random target speeds on the evaluation episodes, each episode's return under
      ``reward_version`` 0 and 1, by outcome; and how many failed episodes return at least
      as much as the worst successful one (0 means the return ranks every success above
      every failure).
    * ``length``: steps to the goal of the supervisor and of random arrivals, with the step
      limit and PPO's discount (``gamma ** steps`` of the arrival).
    * ``observation``: the explicit observation's per-entry standard deviation over those
      episodes (smallest and largest over entries) and largest magnitude, physical and
      normalised.
    """
    from stable_baselines3.common.env_util import make_vec_env

    env_id, base = ABLATION_BASE
    out: dict = {"action": {}}
    for scale in ("physical", "normalized"):
        kwargs = {**base, "action_scale": scale}
        venv = make_vec_env(f"fluids_bench:{env_id}", n_envs=n_envs, seed=seed, env_kwargs=kwargs)
        model = _model("ppo", venv, seed)
        low, high = venv.action_space.low[0], venv.action_space.high[0]
        obs, raw = venv.reset(), []
        for _ in range(model.n_steps):
            action, _ = model.predict(obs, deterministic=False)
            # predict() clips to the Box; redraw the unclipped sample from the distribution
            dist = model.policy.get_distribution(model.policy.obs_to_tensor(obs)[0])
            sample = dist.sample().detach().numpy().reshape(-1)
            raw.append(sample)
            obs, *_ = venv.step(action)
        raw = np.concatenate(raw)
        clipped = np.clip(raw, low, high)
        speed = clipped if scale == "physical" else (clipped + 1.0) * 5.0
        out["action"][scale] = {
            "box": [float(low), float(high)],
            "below_box": round(float(np.mean(raw < low)), 3),
            "mean_target_speed": round(float(speed.mean()), 2),
        }
    # rewards, lengths and observations under random target speeds
    envs = {v: gym.make(env_id, **base, reward_version=v) for v in (0, 1)}
    norm = gym.make(env_id, **base, obs_scale="normalized")
    outcomes: dict = {}
    obs_phys, obs_norm, arrive_steps = [], [], []
    for i in range(episodes):
        s = EVAL_SEED + i
        rets = {}
        for v, env in envs.items():
            rng = np.random.default_rng(s)
            _, info = env.reset(seed=s)
            ret, steps = 0.0, 0
            if v == 0:
                norm.reset(seed=s)
            while True:
                a = rng.uniform(0.0, 10.0, 1).astype(np.float32)
                o, r, term, trunc, info = env.step(a)
                if v == 0:
                    obs_phys.append(o)
                    obs_norm.append(norm.step(a)[0])
                ret += r
                steps += 1
                if term or trunc:
                    break
            rets[v] = ret
        if info.get("is_success"):
            kind = "success"
        elif term and not info["ego_arrived"]:  # a collision ends the episode
            kind = "collision"
        elif info["ego_arrived"]:
            kind = "arrived after a red light or a failure to yield"
        else:
            kind = "timeout"
        if info["ego_arrived"]:
            arrive_steps.append(steps)
        outcomes.setdefault(kind, []).append(rets)
    reward = {"episodes": episodes, "by_outcome": {}}
    for kind, rs in outcomes.items():
        reward["by_outcome"][kind] = {
            "episodes": len(rs),
            **{
                f"mean_return_v{v}": round(float(np.mean([r[v] for r in rs])), 3) + 0.0
                for v in (0, 1)
            },
        }
    for v in (0, 1):
        worst = min((r[v] for r in outcomes.get("success", [])), default=np.inf)
        failed = [r[v] for k, rs in outcomes.items() if k != "success" for r in rs]
        reward[f"failed_at_least_worst_success_v{v}"] = int(sum(x >= worst for x in failed))
    reward["failed_episodes"] = sum(len(rs) for k, rs in outcomes.items() if k != "success")
    out["reward"] = reward
    sup = gym.make(env_id, **base)
    sup_steps = []
    for i in range(20):
        _, info = sup.reset(seed=EVAL_SEED + i)
        steps = 0
        while True:
            *_, term, trunc, info = sup.step(info["supervisor_action"])
            steps += 1
            if term or trunc:
                break
        sup_steps.append(steps)
    out["length"] = {
        "step_limit": int(sup.spec.max_episode_steps),
        "supervisor_mean_steps": round(float(np.mean(sup_steps)), 1),
        "random_arrival_mean_steps": round(float(np.mean(arrive_steps)), 1),
        "gamma": 0.99,
        "discount_at_supervisor_arrival": round(0.99 ** float(np.mean(sup_steps)), 3),
    }
    op, on = np.array(obs_phys), np.array(obs_norm)
    out["observation"] = {
        name: {
            "entries": int(o.shape[1]),
            "std_min": round(float(o.std(0)[o.std(0) > 0].min()), 3),
            "std_max": round(float(o.std(0).max()), 2),
            "abs_max": round(float(np.abs(o).max()), 2),
        }
        for name, o in (("physical", op), ("normalized", on))
    }
    return out


def run_ablation(args, command: str) -> None:
    _torch_on_one_thread()
    env_id, base = ABLATION_BASE
    seed = args.seeds[0]
    print(
        f"expected run time: ~{len(ABLATION_ARMS) * (args.steps / 1000 * 1.2 + 60) / 60:.0f} min "
        "of CPU on 2 cores"
    )
    log = Path(args.work) / "ablation.jsonl"  # finished arms (resumable)
    log.parent.mkdir(parents=True, exist_ok=True)
    done = {}
    if log.is_file():
        for line in log.read_text().splitlines():
            row = json.loads(line)
            if row["steps"] == args.steps and row["episodes"] == args.final_episodes:
                done[row["arm"]] = row
    rows = []
    t0 = time.process_time()
    diagnosis = diagnose(args.final_episodes, seed, args.n_envs)
    print(f"diagnosis: {time.process_time() - t0:.0f} CPU-s")
    random_row = evaluate(env_id, base, _random, args.final_episodes)
    for arm, options in tqdm(ABLATION_ARMS.items(), desc="ablation"):
        if arm in done:
            rows.append(done[arm])
            continue
        from stable_baselines3.common.env_util import make_vec_env

        kwargs = {**base, **options}
        t0 = time.process_time()
        venv = make_vec_env(
            f"fluids_bench:{env_id}", n_envs=args.n_envs, seed=seed, env_kwargs=kwargs
        )
        model = _model("ppo", venv, seed)
        model.learn(total_timesteps=args.steps, progress_bar=False)
        train_s = time.process_time() - t0
        row = {"arm": arm, "options": options, "steps": args.steps, "seed": seed}
        row.update(evaluate(env_id, kwargs, _policy(model), args.final_episodes))
        row["train_cpu_s"] = round(train_s, 1)
        rows.append(row)
        with log.open("a") as f:
            f.write(json.dumps(row) + "\n")
    result = {
        "command": command,
        "env_id": env_id,
        "env_kwargs": base,
        "seeds": [seed],
        "settings": {
            "steps": args.steps,
            "final_episodes": args.final_episodes,
            "eval_seeds": f"{EVAL_SEED} .. {EVAL_SEED + args.final_episodes - 1}",
            "n_envs": args.n_envs,
            "hyperparameters": "stable-baselines3 PPO defaults (MlpPolicy), DummyVecEnv",
            "machine": "2-core CI-class machine, shared, torch CPU build on one thread",
        },
        "diagnosis": diagnosis,
        "random": random_row,
        "arms": rows,
    }
    write_json_atomic(Path(args.out), result)
    for r in rows:
        print(f"{r['arm']:40s} success {r['success_rate']:.2f} timeouts {r.get('timeouts')}")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="FLUIDS-v2", help="a registered Gymnasium id")
    parser.add_argument("--env-kwargs", default="{}", help="JSON kwargs for gym.make")
    parser.add_argument("--algos", nargs="+", choices=("ppo", "sac", "dqn"), default=None,
                        help="default: PPO, and SAC (Box actions) or DQN (Discrete)")  # fmt: skip
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--steps", type=int, default=200_000, help="env steps per run")
    parser.add_argument("--eval-every", type=int, default=50_000)
    parser.add_argument("--eval-episodes", type=int, default=20, help="per curve point")
    parser.add_argument("--final-episodes", type=int, default=200)
    parser.add_argument("--n-envs", type=int, default=2)
    parser.add_argument("--algo-kwargs", default="{}",
                        help='JSON, e.g. \'{"dqn": {"buffer_size": 20000}}\': departures from '
                        "SB3's defaults, recorded in the results")  # fmt: skip
    parser.add_argument("--work", default="runs/rl", help="checkpoints (resumable)")
    parser.add_argument("--out", required=True, help="results JSON")
    parser.add_argument("--image", default=None, help="learning-curve PNG")
    parser.add_argument("--ablation", action="store_true", help="the FLUIDS PPO ablation")
    parser.add_argument("--collect-only", action="store_true",
                        help="train nothing: write the finished runs and the curves so far of "
                        'unfinished ones ("final": null) from --work')  # fmt: skip
    parser.add_argument("--references-only", action="store_true",
                        help="train nothing: re-evaluate the random and supervisor rows of the "
                        "finished --out (after a new teacher is shipped) and redraw --image")  # fmt: skip
    return parser


def main(argv: list[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    given = sys.argv[1:] if argv is None else argv
    command = "python " + " ".join(shlex.quote(a) for a in [sys.argv[0], *relative_paths(given)])
    if args.references_only:
        return refresh_references(args, command)
    (run_ablation if args.ablation else run_curves)(args, command)


if __name__ == "__main__":
    main()
