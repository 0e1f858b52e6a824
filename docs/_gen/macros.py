"""mkdocs-macros hook: the functions pages call as `{{ name(...) }}`.

Everything a page shows about the code (ids, arguments, spaces, env cards, CLI help) or about
measurements (tables from `docs/results/`) comes through here; see `reference.py` and
`results.py` beside this file.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import architecture  # noqa: E402
import benchmark_pages  # noqa: E402
import reference  # noqa: E402
import results  # noqa: E402
import separation  # noqa: E402
import summary  # noqa: E402


def define_env(env) -> None:
    env.macro(reference.env_card)
    env.macro(reference.kwargs_table)
    env.macro(reference.ids_table)
    env.macro(reference.spaces_table)
    env.macro(reference.gallery)
    env.macro(reference.registry_table)
    env.macro(reference.id_guide)
    env.macro(reference.cli_reference)
    env.macro(summary.task_summary)
    env.macro(results.table)
    env.macro(architecture.architecture)
    env.macro(benchmark_pages.benchmark_definition)
    env.macro(benchmark_pages.seed_splits)
    env.macro(benchmark_pages.benchmark_fluids_id)
    env.macro(benchmark_pages.leaderboard)
    env.macro(benchmark_pages.leaderboard_budget)
    env.macro(separation.fluids_separation)
    env.macro(separation.fluids_separation_summary)
    env.macro(separation.fluids_ood_ratio)
    env.macro(separation.driving_score_fix_note)
