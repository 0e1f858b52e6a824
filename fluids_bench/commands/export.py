"""`fluids-bench export --to lerobot DATASET OUT`: write a Minari dataset as a LeRobotDataset.

The LeRobot v3.0 layout, written without lerobot (see `fluids_bench.data.lerobot_export`):
parquet frames, one lossless mp4 per image observation and episode, `meta/info.json`
(features, fps, shapes), episode and task tables. The supervisor's labels are the `action`
feature. Load it with `LeRobotDataset(repo_id, root=OUT)`. Example:

    fluids-bench export --to lerobot fluids/bev-v0 exports/fluids-bev
"""

from __future__ import annotations

import argparse
import json

from fluids_bench.commands import plain_text


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "export",
        help="write a Minari dataset in another library's format (LeRobot)",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--to", choices=["lerobot"], required=True, help="target format")
    parser.add_argument("dataset", metavar="DATASET", help="Minari dataset id (NAMESPACE/NAME-vK)")
    parser.add_argument("out", metavar="OUT", help="output folder (must not exist)")
    parser.add_argument("--fps", type=int, default=None, help="frames per second (default: env's)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing OUT")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import minari

    from fluids_bench.data.lerobot_export import export_lerobot

    info = export_lerobot(
        minari.load_dataset(args.dataset), args.out, fps=args.fps, overwrite=args.overwrite
    )
    keys = {"episodes": info["total_episodes"], "frames": info["total_frames"], "fps": info["fps"]}
    print(json.dumps({"out": args.out, **keys, "features": sorted(info["features"])}))
    return 0
