"""docs/results/client_lerobot.json (scripts/clients/lerobot_roundtrip.py)."""


def render(data, **_):
    v = data["versions"]
    rows = [
        "| check | result |",
        "|---|---|",
        f"| `LeRobotDataset(repo_id, root=...)` loads | {'yes' if data['loaded'] else 'no'} |",
        f"| frames iterated / in the dataset | {data['frames_iterated']} / {data['total_frames']} |",
        f"| episodes, fps | {data['episodes']}, {data['fps']} |",
        f"| video features | {', '.join(data['video_keys']) or '(none)'} |",
        f"| labels equal the parquet's | {'yes' if data['labels_equal_parquet'] else 'no'} |",
        f"| largest decoded-pixel difference (0–255) | {data['max_video_pixel_error']:g} |",
    ]
    if "stats_features" in data:
        rows += [
            f"| `meta/stats.json` read by lerobot: features | {len(data['stats_features'])} "
            f"({', '.join(data['stats_keys'])}) |",
            f"| largest difference of a stats mean from the frames' | "
            f"{data['stats_max_mean_error']:.1e} |",
        ]
    return (
        "\n".join(rows) + f"\n\nlerobot {v['lerobot']} on torch {v['torch']}, video backend"
        f" `{data['video_backend']}`. Machine: {data['machine']}."
        f" Command: `{data['command']}`."
    )
