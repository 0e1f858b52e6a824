"""Train a locomotion supervisor policy with Augmented Random Search (ARS V2-t), in numpy.

ARS (Mania, Guy and Recht 2018) perturbs the policy parameters in ``n_directions`` random
directions, runs one episode with ``+nu*delta`` and one with ``-nu*delta``, keeps the ``top``
best directions and steps along their reward differences, scaled by the rewards' std. States are
normalised by running statistics of every state seen in training (V2). The policy is
:class:`fluids_bench.tasks.locomotion.policy.MLPPolicy` (tanh-squashed output, so not linear in
the observation); ``--hidden`` adds tanh hidden layers (default: none).

Rollouts run Gymnasium's own ``<Name>-v5`` env (the env the supervisor will act in), each
episode reset with its own seed drawn from the run's seeded generator, so the run is a pure
function of its settings whatever ``--workers`` is. As in the ARS paper, the per-step survival
bonus is subtracted from the training reward (``--shift``); evaluations use the env's reward.

Resumable: the state after every iteration is written atomically to ``<out>.ckpt.npz``; run the
same command again to continue. Ctrl-C stops cleanly after the current iteration's checkpoint.
``--init <other>.ckpt.npz`` starts a new stage from another run's checkpoint (its parameters,
state statistics, random generator and iteration count) with this command's settings, e.g.
another ``--shift``; the stage's recipe records the one it started from. ``--init-weights
<file>.npz`` starts a stage from a weight file alone (a shipped expert: its parameters, and its
normaliser as the statistics of ``--init-obs-count`` states), with a fresh generator; a file
this script wrote (its ``<file>.json`` beside it) or whose sha256 the shipped manifest records
also carries on that run's iteration count and cost.

``--action-noise S`` trains a teacher that tolerates the noise imitation learning injects: every
executed action is ``clip(policy(obs) + N(0, S^2 I), low, high)`` (the noise drawn from the
episode's seed), in training and in a second set of evaluation episodes; the best policy is then
the one with the highest mean over the clean and the noisy evaluation episodes.
``--paired-seeds`` runs a direction's two episodes from one seed (the same initial state and, with
``--action-noise``, the same noise): common random numbers, so their difference measures the
direction rather than which episode drew the unlucky noise.
Writes ``<out>`` (the best evaluated policy, .npz) and ``<out>.json`` (recipe, history, sha256).

Example: ``nice -n 10 python scripts/training/train_locomotion_expert.py --env Hopper --iterations 400
--out runs/hopper.npz --workers 2``
"""

from __future__ import annotations

import argparse
import hashlib
import json
import multiprocessing as mp
import os
import signal
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

from fluids_bench.core.provenance import announce
from fluids_bench.tasks.locomotion.policy import MLPPolicy, sha256_of
from fluids_bench.tasks.locomotion.supervisors import manifest

# The ARS paper's V2-t settings per task (Table 9 of arXiv:1803.07055), shift = survival bonus.
PRESETS = {
    "Hopper": dict(n_directions=8, top=4, step_size=0.01, noise=0.025, shift=1.0),
    "Walker2d": dict(n_directions=40, top=30, step_size=0.025, noise=0.01, shift=1.0),
    "HalfCheetah": dict(n_directions=32, top=4, step_size=0.02, noise=0.03, shift=0.0),
    "Humanoid": dict(n_directions=230, top=230, step_size=0.02, noise=0.0075, shift=5.0),
}

_ENVS: dict[str, gym.Env] = {}


def _env(name: str) -> gym.Env:
    if name not in _ENVS:
        _ENVS[name] = gym.make(f"{name}-v5", disable_env_checker=True).unwrapped
    return _ENVS[name]


def build_policy(theta, shapes, obs_mean, obs_std, low, high) -> MLPPolicy:
    weights, biases, i = [], [], 0
    for out_dim, in_dim in shapes:
        weights.append(theta[i : i + out_dim * in_dim].reshape(out_dim, in_dim))
        i += out_dim * in_dim
        biases.append(theta[i : i + out_dim])
        i += out_dim
    return MLPPolicy(obs_mean, obs_std, weights, biases, low, high)


# the action-noise generator of an episode: its seed and this tag (not the env's own stream)
NOISE_STREAM = 0x0A11


def rollout(job):
    """One episode: returns (return with shift, env return, steps, sum obs, sum obs^2).
    ``action_noise`` > 0: the executed action is the policy's plus N(0, action_noise^2 I),
    clipped to the action space, drawn from the episode's seed."""
    name, theta, shapes, obs_mean, obs_std, seed, shift, horizon, action_noise = job
    env = _env(name)
    low, high = env.action_space.low, env.action_space.high
    policy = build_policy(theta, shapes, obs_mean, obs_std, low, high)
    obs, _ = env.reset(seed=int(seed))
    noise = np.random.default_rng([int(seed), NOISE_STREAM]) if action_noise else None
    total, steps = 0.0, 0
    s1 = np.zeros_like(obs_mean)
    s2 = np.zeros_like(obs_mean)
    for _ in range(horizon):
        s1 += obs
        s2 += obs * obs
        action = policy(obs)
        if noise is not None:
            action = np.clip(action + action_noise * noise.standard_normal(action.shape), low, high)
        obs, reward, terminated, _, _ = env.step(action)
        total += reward
        steps += 1
        if terminated:
            break
    return total - shift * steps, total, steps, s1, s2


def layer_shapes(obs_dim: int, act_dim: int, hidden: list[int]) -> list[tuple[int, int]]:
    dims = [obs_dim, *hidden, act_dim]
    return [(dims[i + 1], dims[i]) for i in range(len(dims) - 1)]


def atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp.write_bytes(data)
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", required=True, choices=sorted(PRESETS))
    p.add_argument("--out", required=True, type=Path, help="weight file to write (.npz)")
    p.add_argument("--iterations", type=int, default=300)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--hidden", type=int, nargs="*", default=[], help="tanh hidden widths")
    p.add_argument("--horizon", type=int, default=1000)
    p.add_argument(
        "--obs-dims",
        type=int,
        default=None,
        help="the policy reads only the observation's first K entries (Humanoid: 45, its joint "
        "positions and velocities); the rest get zero weight (default: all)",
    )
    p.add_argument("--eval-every", type=int, default=10)
    p.add_argument("--eval-episodes", type=int, default=5)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument(
        "--init",
        type=Path,
        default=None,
        help="start from this checkpoint (<out>.ckpt.npz of an earlier stage), not from zero",
    )
    p.add_argument(
        "--init-weights",
        type=Path,
        default=None,
        help="start from this weight file (.npz, e.g. a shipped expert), not from zero",
    )
    p.add_argument(
        "--init-obs-count",
        type=float,
        default=1e6,
        help="with --init-weights: the file's normaliser counts as the statistics of this many "
        "states (larger: the states of the new stage move it less)",
    )
    p.add_argument(
        "--action-noise",
        type=float,
        default=0.0,
        help="std of the Gaussian noise added to every executed action in training, and in a "
        "second set of evaluation episodes (default 0: none)",
    )
    p.add_argument(
        "--paired-seeds",
        action="store_true",
        help="a direction's +/- episodes share one seed (initial state and action noise), "
        "so noise that fells one episode fells both (default: a seed each)",
    )
    p.add_argument(
        "--ship",
        type=Path,
        default=None,
        help="copy the best weights so far into this folder as <env>.npz and record them in its "
        "manifest.json (sha256, recipe, evaluation); trains nothing",
    )
    for key in ("n_directions", "top"):
        p.add_argument("--" + key.replace("_", "-"), type=int, default=None)
    for key in ("step_size", "noise", "shift"):
        p.add_argument("--" + key.replace("_", "-"), type=float, default=None)
    args = p.parse_args(argv)
    announce(
        "hours for a full recipe (tens of millions of env steps; Humanoid ~2 h on 2 free cores); a few seconds per iteration"
    )
    hp = dict(PRESETS[args.env])
    for key in hp:
        if getattr(args, key) is not None:
            hp[key] = getattr(args, key)
    if not 1 <= hp["top"] <= hp["n_directions"]:
        p.error(f"--top is {hp['top']}; allowed: 1..--n-directions ({hp['n_directions']})")
    if not (np.isfinite(args.action_noise) and args.action_noise >= 0):
        p.error(f"--action-noise is {args.action_noise}; allowed: a finite number >= 0")
    if not (np.isfinite(args.init_obs_count) and args.init_obs_count >= 2):
        p.error(f"--init-obs-count is {args.init_obs_count}; allowed: a finite number >= 2")
    if args.init is not None and args.init_weights is not None:
        p.error("--init and --init-weights are both given; allowed: one of the two")

    if args.ship is not None:
        return ship(args.env, args.out, args.ship)
    env = _env(args.env)
    obs_dim = env.observation_space.shape[0]
    act_dim = env.action_space.shape[0]
    low, high = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    shapes = layer_shapes(obs_dim, act_dim, args.hidden)
    n_params = sum(o * i + o for o, i in shapes)
    obs_dims = obs_dim if args.obs_dims is None else args.obs_dims
    if not 1 <= obs_dims <= obs_dim:
        p.error(f"--obs-dims is {obs_dims}; allowed: 1..{obs_dim} for {args.env}")
    # the parameters searched: all but the first layer's weights on unread observation entries
    free = np.ones(n_params, dtype=bool)
    free[: shapes[0][0] * obs_dim] = np.tile(np.arange(obs_dim) < obs_dims, shapes[0][0])
    n_free = int(free.sum())
    recipe = {
        "algorithm": "ARS V2-t (Mania et al. 2018), numpy",
        "env": f"{args.env}-v5",
        "seed": args.seed,
        "hidden": args.hidden,
        "obs_dims": obs_dims,
        "horizon": args.horizon,
        "eval_every": args.eval_every,
        "eval_episodes": args.eval_episodes,
        "eval_seeds": f"10_000_000 + range({args.eval_episodes})",
        **hp,
        "action_noise": args.action_noise,
        "paired_seeds": args.paired_seeds,
        "command": "python scripts/training/train_locomotion_expert.py " + " ".join(sys.argv[1:]),
    }

    ckpt = args.out.with_name(args.out.name + ".ckpt.npz")
    meta_path = args.out.with_name(args.out.name + ".json")
    rng = np.random.default_rng(args.seed)
    if args.init is not None and not ckpt.exists():
        if not args.init.name.endswith(".ckpt.npz") or not args.init.exists():
            p.error(f"--init is {args.init}; allowed: an existing <out>.ckpt.npz of another run")
    resume_from = ckpt if ckpt.exists() else args.init
    if resume_from is None and args.init_weights is not None:
        theta, n, s1, s2, recipe["init"] = from_weights(
            args.init_weights, shapes, low, high, args.init_obs_count, p.error
        )
        best_theta, (best_mean, best_std) = theta.copy(), _moments(n, s1, s2)
        # the iteration count and cost so far carried on, as --init does (known when the file
        # is a shipped one); --iterations counts from the first stage's start
        start = recipe["init"].get("iteration", 0)
        history, best = [], {"mean_return": -np.inf, "iteration": start}
        elapsed = recipe["init"].get("training_seconds", 0.0)
        env_steps = recipe["init"].get("training_env_steps", 0)
        print(f"new stage from the weights {args.init_weights}")
    elif resume_from is not None:
        with np.load(resume_from, allow_pickle=False) as z:
            theta = z["theta"]
            best_theta, best_mean, best_std = z["best_theta"], z["best_mean"], z["best_std"]
            n, s1, s2 = float(z["n"]), z["s1"], z["s2"]
            state = json.loads(str(z["state"]))
        rng.bit_generator.state = state["rng"]
        start, history, best = state["iteration"], state["history"], state["best"]
        elapsed, env_steps = state["elapsed"], state["env_steps"]
        if (
            state["recipe"]["seed"],
            state["recipe"]["hidden"],
            state["recipe"].get("obs_dims", obs_dim),
        ) != (args.seed, args.hidden, obs_dims):
            p.error(f"checkpoint {resume_from} was made with other settings: {state['recipe']}")
        if resume_from == ckpt:
            if "init" in state["recipe"]:
                recipe["init"] = state["recipe"]["init"]
            print(f"resuming at iteration {start} (best eval {best['mean_return']:.1f})")
        else:  # a new stage: its own history and best, the cost so far carried on
            recipe["init"] = {
                "checkpoint": args.init.name,
                "iteration": start,
                "sha256": sha256_of(args.init),
                "recipe": state["recipe"],
            }
            history, best = [], {"mean_return": -np.inf, "iteration": start}
            print(f"new stage from {args.init} at iteration {start}")
    else:
        theta = np.zeros(n_params)
        # hidden layers start random (output layer zero, so the first policy outputs mid-range)
        i = 0
        for o, inp in shapes[:-1]:
            theta[i : i + o * inp] = rng.standard_normal(o * inp) / np.sqrt(inp)
            i += o * inp + o
        theta[~free] = 0.0
        n, s1, s2 = 0.0, np.zeros(obs_dim), np.zeros(obs_dim)
        start, history, best = 0, [], {"mean_return": -np.inf, "iteration": 0}
        best_theta, best_mean, best_std = theta.copy(), np.zeros(obs_dim), np.ones(obs_dim)
        elapsed, env_steps = 0.0, 0

    def normaliser():
        return _moments(n, s1, s2)

    # workers ignore Ctrl-C (a terminal sends it to them too): the main process stops them
    # after its checkpoint, without a KeyboardInterrupt traceback from every worker
    pool = (
        mp.get_context("fork").Pool(
            args.workers, initializer=signal.signal, initargs=(signal.SIGINT, signal.SIG_IGN)
        )
        if args.workers > 1
        else None
    )
    run = pool.map if pool else lambda f, jobs: list(map(f, jobs))
    N, b = hp["n_directions"], hp["top"]
    try:
        for it in range(start, args.iterations):
            t0 = time.perf_counter()
            mean, std = normaliser()
            deltas = np.zeros((N, n_params))
            deltas[:, free] = rng.standard_normal((N, n_free))
            seeds = rng.integers(0, 2**31 - 1, size=(N, 2))
            if args.paired_seeds:  # drawn as without, so the generator's stream is the same
                seeds[:, 1] = seeds[:, 0]
            jobs = []
            for k in range(N):
                for sign, col in ((1.0, 0), (-1.0, 1)):
                    th = theta + sign * hp["noise"] * deltas[k]
                    jobs.append(
                        (
                            args.env,
                            th,
                            shapes,
                            mean,
                            std,
                            seeds[k, col],
                            hp["shift"],
                            args.horizon,
                            args.action_noise,
                        )
                    )
            results = run(rollout, jobs)
            r = np.array([res[0] for res in results]).reshape(N, 2)
            for res in results:
                n += res[2]
                s1 = s1 + res[3]
                s2 = s2 + res[4]
                env_steps += res[2]
            order = np.argsort(-np.max(r, axis=1), kind="stable")[:b]
            sigma_r = r[order].std()
            if sigma_r > 0:
                theta = theta + hp["step_size"] / (b * sigma_r) * (
                    (r[order, 0] - r[order, 1]) @ deltas[order]
                )
            row = {
                "iteration": it + 1,
                "train_mean_return": float(np.mean([x[1] for x in results])),
            }
            if (it + 1) % args.eval_every == 0 or it + 1 == args.iterations:
                mean, std = normaliser()
                # clean episodes, then (with --action-noise) the same seeds with noise
                levels = [0.0] + ([args.action_noise] if args.action_noise else [])
                evals = run(
                    rollout,
                    [
                        (args.env, theta, shapes, mean, std, 10_000_000 + e, 0.0, args.horizon, a)
                        for a in levels
                        for e in range(args.eval_episodes)
                    ],
                )
                rets = [x[1] for x in evals]
                row.update(
                    eval_mean=float(np.mean(rets)),
                    eval_min=float(np.min(rets)),
                    eval_steps=[int(x[2]) for x in evals],
                )
                if args.action_noise:
                    clean = rets[: args.eval_episodes]
                    row.update(
                        eval_clean_mean=float(np.mean(clean)),
                        eval_noisy_mean=float(np.mean(rets[args.eval_episodes :])),
                    )
                env_steps += sum(x[2] for x in evals)
                if row["eval_mean"] > best["mean_return"]:
                    best = {
                        "mean_return": row["eval_mean"],
                        "iteration": it + 1,
                        "min_return": row["eval_min"],
                        "steps": row["eval_steps"],
                    }
                    for k in ("eval_clean_mean", "eval_noisy_mean"):
                        if k in row:
                            best[k] = row[k]
                    best_theta, best_mean, best_std = theta.copy(), mean, std
                    policy = build_policy(best_theta, shapes, best_mean, best_std, low, high)
                    atomic_write(args.out, policy.to_bytes())
            elapsed += time.perf_counter() - t0
            row.update(elapsed_s=round(elapsed, 1), env_steps=int(env_steps))
            history.append(row)
            print(json.dumps(row), flush=True)
            state = {
                "iteration": it + 1,
                "history": history,
                "best": best,
                "elapsed": elapsed,
                "env_steps": int(env_steps),
                "rng": rng.bit_generator.state,
                "recipe": recipe,
            }
            buf_path = ckpt.with_name(ckpt.name + ".tmp.npz")
            np.savez(
                buf_path,
                theta=theta,
                best_theta=best_theta,
                best_mean=best_mean,
                best_std=best_std,
                n=n,
                s1=s1,
                s2=s2,
                state=json.dumps(state),
            )
            os.replace(buf_path, ckpt)
            if args.out.exists():
                meta = {
                    "recipe": recipe,
                    "best": best,
                    "iterations_done": it + 1,
                    "elapsed_s": round(elapsed, 1),
                    "env_steps": int(env_steps),
                    "sha256": sha256_of(args.out),
                    "history": history,
                }
                atomic_write(meta_path, json.dumps(meta, indent=1).encode())
    except KeyboardInterrupt:
        print("interrupted: the last finished iteration is checkpointed", file=sys.stderr)
        return 130
    finally:
        if pool:
            pool.terminate()
    return 0


def _moments(n: float, s1: np.ndarray, s2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The state normaliser (mean, std) of ``n`` states with sums ``s1`` and squares ``s2``."""
    if n < 2:
        return np.zeros_like(s1), np.ones_like(s1)
    mean = s1 / n
    var = np.maximum(s2 / n - mean * mean, 0.0)
    std = np.sqrt(var)
    std[std < 1e-7] = np.inf  # a constant input carries no information
    return mean, std


def from_weights(path: Path, shapes, low, high, count: float, error):
    """A stage's start from a weight file: (theta, n, s1, s2, the recipe's "init" record).

    The file's normaliser becomes the sums of ``count`` states with its mean and std (an
    infinite std, an ignored input, as a constant one)."""
    try:
        policy = MLPPolicy.from_bytes(path.read_bytes())
    except (OSError, ValueError) as e:
        error(f"--init-weights is {path}; allowed: a readable weight file ({e})")
    file_shapes = [w.shape for w in policy.weights]
    if file_shapes != list(shapes):
        error(
            f"--init-weights {path} has layers {file_shapes}; allowed: this run's {list(shapes)} "
            "(set --hidden to the file's hidden widths)"
        )
    if not (np.array_equal(policy.action_low, low) and np.array_equal(policy.action_high, high)):
        error(f"--init-weights {path} has other action bounds than the env's")
    theta = np.concatenate(
        [a.ravel() for w, b in zip(policy.weights, policy.biases, strict=True) for a in (w, b)]
    )
    mean = policy.obs_mean
    var = np.where(np.isfinite(policy.obs_std), policy.obs_std**2, 0.0)
    s1, s2 = count * mean, count * (var + mean * mean)
    record = {"weights": path.name, "sha256": sha256_of(path), "obs_count": count}
    # the file's own run: the record this script wrote next to it, or the shipped manifest's
    # (a shipped file or a copy of one); either gives the same iteration to carry on from
    meta_path = path.with_name(path.name + ".json")
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    if meta.get("sha256") == record["sha256"]:
        record["iteration"] = meta["best"]["iteration"]
        record["recipe"] = meta["recipe"]
        record["training_env_steps"] = meta["env_steps"]
        record["training_seconds"] = meta["elapsed_s"]
    else:
        for entry in manifest().values():
            if entry["sha256"] == record["sha256"]:
                record["iteration"] = entry["selected_at_iteration"]
                record["recipe"] = entry["recipe"]
                record["training_env_steps"] = entry["training_env_steps"]
                record["training_seconds"] = entry["training_seconds"]
    return theta, float(count), s1, s2, record


def ship(name: str, weights: Path, folder: Path) -> int:
    """Copy ``weights`` into ``folder`` and record it in ``folder/manifest.json``."""
    meta = json.loads(weights.with_name(weights.name + ".json").read_text())
    data = weights.read_bytes()
    if hashlib.sha256(data).hexdigest() != meta["sha256"]:
        raise SystemExit(f"{weights} changed since its record was written; rerun training")
    folder.mkdir(parents=True, exist_ok=True)
    target = f"{name.lower()}.npz"
    atomic_write(folder / target, data)
    manifest_path = folder / "manifest.json"
    manifest = json.loads(manifest_path.read_text()) if manifest_path.exists() else {}
    manifest[name] = {
        "file": target,
        "sha256": meta["sha256"],
        "recipe": meta["recipe"],
        "selected_at_iteration": meta["best"]["iteration"],
        "training_eval": meta["best"],
        "training_iterations_run": meta["iterations_done"],
        "training_seconds": meta["elapsed_s"],
        "training_env_steps": meta["env_steps"],
    }
    atomic_write(manifest_path, (json.dumps(manifest, indent=1, sort_keys=True) + "\n").encode())
    print(f"shipped {weights} as {folder / target} (sha256 {meta['sha256']})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
