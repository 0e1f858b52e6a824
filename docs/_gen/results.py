"""Tables read from the results files under `docs/results/`.

A page never holds a measured number by hand: it calls `table("<name>")`, which loads
`docs/results/<name>.json` and renders it with `docs/_gen/tables/<name>.py`'s
`render(data) -> str` (files of one layout share one, see `SHARED_RENDERERS`; a
renderer may take keyword arguments for a part of its file: `table("x", part="speed")`).
Each results file names the command that wrote it (`"command"`), shown under the table.
`table("<name>", optional=True)` renders a line saying the file is not there yet instead of
failing (a scorecard a running job will write).
"""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
RESULTS = DOCS / "results"
TABLES = Path(__file__).resolve().parent / "tables"


def load(name: str) -> dict:
    path = RESULTS / f"{name}.json"
    if not path.is_file():
        raise FileNotFoundError(f"results file {path} is missing; the page's table reads it")
    return json.loads(path.read_text())


# results files of one layout share a renderer (the runs of one script with other settings)
SHARED_RENDERERS = (
    (r"dart_mujoco_.+", "dart_mujoco"),
    (r"reproduce_grasping_shiv_.+", "reproduce_grasping_shiv"),
    (r"reproduce_track_shiv_.+", "reproduce_track_shiv"),
    (r"sweep_(singulation|singulation_size|track|grasping|fluids)", "sweep_study"),
    (r"bench_(singulation|grasping)", "bench_tasks"),
    (r"rl_(dag|singulation|grasping|track)", "rl_tasks"),
    (r"rl_(hopper|walker2d|halfcheetah|humanoid)(_sac)?", "rl_tasks"),
    (r"rl_fluids_v2_(2m|sac|end_on_violation_2m)|rl_fluids_v3(_1m)?", "rl_fluids_v2"),
    (r"fluids_v4_scores_.+", "fluids_v4_scores"),
    (r"scorecard_.+", "scorecard"),  # fluids-bench evaluate's scorecards
)


def renderer_name(name: str) -> str:
    for pattern, shared in SHARED_RENDERERS:
        if re.fullmatch(pattern, name):
            return shared
    return name


def renderer(name: str):
    name = renderer_name(name)
    path = TABLES / f"{name}.py"
    if not path.is_file():
        raise FileNotFoundError(f"no renderer {path} for docs/results/{name}.json")
    spec = importlib.util.spec_from_file_location(f"docs_tables_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.render


def table(name: str, optional: bool = False, **options) -> str:
    """The rendered table of `docs/results/<name>.json`, with the command that produced it;
    with `optional`, a missing file gives a line saying so."""
    if optional and not (RESULTS / f"{name}.json").is_file():
        return f"*`docs/results/{name}.json` is not there yet.*"
    data = load(name)
    out = renderer(name)(data, **options)
    command = data.get("command") if isinstance(data, dict) else None
    if command and not options.get("no_command"):
        out += f"\n\n<small>From `docs/results/{name}.json`, written by `{command}`.</small>"
    return out
