"""LeRobot as a client: a dataset written by ``fluids-bench export --to lerobot`` loads with
lerobot's own ``LeRobotDataset(repo_id, root=...)`` and iterates (video frames decoded by lerobot,
states and supervisor labels as tensors), and lerobot reads its ``meta/stats.json`` (every
feature's statistics, whose means agree with the frames lerobot returns). Writes ``docs/results/client_lerobot.json`` (read by
docs/ecosystem.md).

lerobot 0.4.4 pins ``torch<2.11`` (only CUDA builds of those on this index: ``pip install
lerobot==0.4.4`` in its own venv pulls torch 2.10.0+cu128, about 5 GB, which runs on CPU; torch
2.13.0+cpu with torchvision 0.28 does not work, that torchvision being a CUDA build). Its default
video decoder, torchcodec, needs the system's FFmpeg libraries, so this reads videos with pyav.
The export is made with the suite's own interpreter beforehand::

    export MINARI_DATASETS_PATH=runs/lerobot-minari
    fluids-bench collect --env FLUIDS-v3 --episodes 2 --max-steps 30 --dataset clients/bev-v0 \
        --env-kwarg 'obs_type=["birdseye","explicit"]'
    fluids-bench export --to lerobot clients/bev-v0 runs/lerobot-bev
    .venv-lerobot/bin/python scripts/clients/lerobot_roundtrip.py runs/lerobot-bev
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# the suite's provenance helpers, read without importing fluids_bench (not installed in this venv)
_spec = importlib.util.spec_from_file_location(
    "provenance", ROOT / "fluids_bench/core/provenance.py"
)
provenance = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(provenance)
command_line, machine = provenance.command_line, provenance.machine


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", help="the exported LeRobotDataset folder")
    parser.add_argument("--out", default=str(ROOT / "docs/results/client_lerobot.json"))
    # lerobot's default decoder, torchcodec, needs the system's FFmpeg libraries (libavutil ...);
    # pyav ships its own
    parser.add_argument("--video-backend", default="pyav", choices=["pyav", "torchcodec"])
    args = parser.parse_args()

    import numpy as np
    import pyarrow.parquet as pq
    import torch
    from lerobot import __version__ as lerobot_version
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root = Path(args.root)
    ds = LeRobotDataset("fluids-bench/export", root=root, video_backend=args.video_backend)
    info = json.loads((root / "meta/info.json").read_text())
    frames = pq.read_table(root / "data/chunk-000/file-000.parquet").to_pydict()
    video_keys = list(ds.meta.video_keys)
    channel_sums = {key: np.zeros(3) for key in video_keys}
    max_video_error = 0.0
    labels_equal = True
    n = 0
    loader = torch.utils.data.DataLoader(ds, batch_size=1, shuffle=False)
    for item in loader:
        i = int(item["index"][0])
        action = item["action"][0].numpy()
        labels_equal &= bool(np.array_equal(action, np.asarray(frames["action"][i], action.dtype)))
        for key in video_keys:
            assert item[key].shape[1:] == (3, *info["features"][key]["shape"][:2]), item[key].shape
            channel_sums[key] += item[key][0].double().mean(dim=(1, 2)).numpy()
        n += 1
    # lerobot gives frames as float CHW in [0, 1]; compare one episode's with the mp4's own frames
    if video_keys:
        import imageio.v3 as iio

        key = video_keys[0]
        ep = ds.meta.episodes[0]
        path = root / ds.meta.get_video_file_path(0, key)
        raw = iio.imread(path)
        for j in range(ep["dataset_from_index"], ep["dataset_to_index"]):
            got = (ds[j][key].permute(1, 2, 0).numpy() * 255).round()
            max_video_error = max(max_video_error, float(np.abs(got - raw[j]).max()))
    # lerobot's view of meta/stats.json (numpy arrays): every feature, LeRobot's shapes, and
    # means that agree with the frames (parquet columns; video frames as lerobot decodes them)
    stats = ds.meta.stats
    stats_mean_error = 0.0
    for key in info["features"]:
        if key in video_keys:
            assert stats[key]["mean"].shape == (3, 1, 1), stats[key]["mean"].shape
            got = channel_sums[key] / n
        else:
            got = np.asarray(frames[key], np.float64).reshape(n, -1).mean(axis=0)
        error = np.abs(np.asarray(stats[key]["mean"], np.float64).reshape(-1) - got).max()
        stats_mean_error = max(stats_mean_error, float(error))
    result = {
        "loaded": True,
        "frames_iterated": n,
        "total_frames": ds.num_frames,
        "episodes": ds.num_episodes,
        "fps": ds.fps,
        "video_keys": video_keys,
        "features": sorted(ds.features),
        "video_backend": ds.video_backend,
        "labels_equal_parquet": labels_equal,
        "max_video_pixel_error": max_video_error,
        "stats_features": sorted(stats),
        "stats_keys": sorted(next(iter(stats.values()))),
        "stats_image_mean_shape": [list(stats[k]["mean"].shape) for k in video_keys],
        "stats_max_mean_error": stats_mean_error,
        "versions": {"lerobot": lerobot_version, "torch": torch.__version__},
        "command": command_line(),
        "machine": machine(),
    }
    out = Path(args.out)
    with tempfile.NamedTemporaryFile("w", dir=out.parent, suffix=".tmp", delete=False) as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    os.replace(f.name, out)
    print(json.dumps({k: result[k] for k in ("frames_iterated", "total_frames", "video_keys")}))
    if n != info["total_frames"] or not labels_equal:
        sys.exit("lerobot did not iterate every frame with its label")
    if sorted(stats) != sorted(info["features"]) or stats_mean_error > 1e-5:
        sys.exit(f"lerobot's stats disagree with the frames (max mean error {stats_mean_error})")


if __name__ == "__main__":
    main()
