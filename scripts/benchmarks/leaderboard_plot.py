"""Draw the leaderboard's figure from the scorecards in docs/results/ (scorecard_*.json).

    python scripts/benchmarks/leaderboard_plot.py --out docs/images/leaderboard.png

Per task, the normalised score of every full-suite scorecard's policy (all episodes of every
task; `--all` adds the shortened and one-task cards) with its 95 % interval, on the test split and
on the OOD sets, and the suite's mean and IQM; label-efficiency curves when a scorecard has them.
Seconds: it only reads JSON.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from fluids_bench.benchmark.plots import plot_scorecards

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=ROOT / "docs" / "results")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images" / "leaderboard.png")
    parser.add_argument("--all", action="store_true", help="also the shortened scorecards")
    args = parser.parse_args()
    paths = sorted(args.results.glob("scorecard_*.json"))
    if not paths:
        raise SystemExit(f"no scorecard_*.json in {args.results}")
    cards = [json.loads(p.read_text()) for p in paths]
    if not args.all:  # one figure people can read: the full-suite cards only
        cards = [c for c in cards if not c["suite"]["shortened"]] or cards
    order = {"supervisor": 0, "random": 2}
    cards.sort(key=lambda c: (order.get(c["policy"]["name"], 1), c["policy"]["name"]))
    plot_scorecards(cards, args.out)
    print(f"wrote {args.out} from {len(cards)} scorecards")


if __name__ == "__main__":
    main()
