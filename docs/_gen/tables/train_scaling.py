"""docs/results/train_scaling.json (scripts/benchmarks/bench_train_scaling.py)."""


def render(data, **_):
    s = data["settings"]
    m = data["machine"]
    rows = [
        "| backend | workers | wall time (median) | runs | speed-up | CPU time (median) |",
        "|---|---|---|---|---|---|",
    ]
    for r in data["runs"]:
        runs = ", ".join(f"{x:.1f}" for x in r["seconds"])
        speedup = "n/a" if r["speedup"] is None else f"{r['speedup']:.2f}x"
        rows.append(
            f"| {r['backend']} | {r['workers']} | {r['median_seconds']:.1f} s | {runs} s "
            f"| {speedup} | {r['median_cpu_seconds']:.1f} s |"
        )
    load = ", ".join(f"{x:.1f}" for x in m["load_average_before"])
    return (
        "\n".join(rows)
        + f"\n\n`{data['runs'][-1]['command']}` and the same with other workers or backend:"
        f" {s['algo']} on `{s['env']}`, {s['demos_per_iteration']} rollouts per iteration, {s['iterations']} iterations"
        f" ({s['rollouts']} rollouts in all, the initial demonstration included) and {s['eval_episodes']} evaluation episodes at each"
        f" evaluation ({s['evaluation_episodes']} in all, the supervisor's included), seed"
        f" {', '.join(map(str, data['seeds']))}. Wall time of the whole command (start-up,"
        f" rollouts, fits, evaluation, output), {s['repeats']} runs per row, alternating; speed-up"
        f" against one worker. CPU time: the command and every process it started (workers, fork"
        f" server, Ray), sampled every 0.25 s. Records identical across all runs:"
        f" {'yes' if data['identical_records'] else 'NO'}. Machine: {m['cpus']} cores"
        f" (load average {load} before the runs), Python {m['python']}."
    )
