"""docs/results/bench_track.json (scripts/benchmarks/bench_track.py --results): DrivingTrack speed
(`part="env"`) and the cost of its pieces (`part="pieces"`)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # docs/_gen: benchfmt

from benchfmt import machine_line, n  # noqa: E402

CASES = {
    "hog": "`DrivingTrack-v0` (HOG, depth-8 search)",
    "hog_source": "`DrivingTrack-Source-v0` (HOG, depth 1)",
    "pixels": '`obs_type="pixels"`',
    "state": '`obs_type="state"`',
}
PIECES = {
    "label_depth_1_us": "label, depth-1 search",
    "label_depth_4_us": "label, depth-4 search",
    "label_depth_8_us": "label, depth-8 search",
    "label_depth_10_us": "label, depth-10 search",
    "frame_us": "125×125 frame",
    "frame_full_pipeline_us": "frame, drawing and downsampling the 500×500 image",
    "hog_us": "HOG descriptor",
}


def render(data, part: str = "env", **_) -> str:
    if part == "pieces":
        out = ["| piece | CPU µs per call |", "|---|---|"]
        for k, label in PIECES.items():
            if k in data["pieces_cpu_us"]:
                out.append(f"| {label} | {data['pieces_cpu_us'][k]:.1f} |")
        return "\n".join(out)
    out = ["| case | steps/s (wall) | steps per CPU-second |", "|---|---|---|"]
    for k, label in CASES.items():
        r = data[k]
        out.append(f"| {label} | {n(r['steps_per_s'])} | {n(r['steps_per_cpu_s'])} |")
    return (
        "\n".join(out)
        + f"\n\n{data['steps']} steps per case, a label every step. "
        + machine_line(data)
    )
