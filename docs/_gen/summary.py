"""The one-screen summary at the top of every task page: a moving picture of the env under its
supervisor (`docs/images/anim_<name>.gif`, written by `scripts/figures/make_task_gifs.py`), the
family's ids, how to make the page's main id, its spaces and where the label is.

A page calls `{{ task_summary("<family slug>", "<gif name>", "<main id>") }}` right under its
title; tests/docs check that every page of `docs/tasks/` does, and that the GIF is in the first
screen of the rendered page.
"""

from __future__ import annotations

from reference import PARALLEL_ENV_SPECS, _md_cell, _spaces, family


def _make_line(env_id: str) -> str:
    if env_id in PARALLEL_ENV_SPECS:
        return (
            f'`import pettingzoo, fluids_bench` then `pettingzoo.make("parallel", "{env_id}")`; '
            'each agent\'s label is `infos[agent]["supervisor_action"]`'
        )
    return (
        f'`import gymnasium as gym, fluids_bench` then `gym.make("{env_id}")`; '
        'the supervisor\'s label is `info["supervisor_action"]` after every reset and step'
    )


def task_summary(slug: str, gif: str, env_id: str, caption: str = "") -> str:
    """The summary block of family `slug`'s page: `gif` names `docs/images/anim_<gif>.gif`,
    `env_id` the id whose spaces are shown (one of the family's ids)."""
    f = family(slug)
    ids = f.ids + f.parallel_ids
    if env_id not in ids:
        raise ValueError(f"env_id is {env_id!r}; allowed: one of {slug}'s ids {list(ids)}")
    action, observation = _spaces(env_id)
    caption = caption or f"{env_id}: one seeded episode under its supervisor"
    shown = ", ".join(f"`{i}`" for i in ids)
    return "\n".join(
        [
            '<div class="task-summary" markdown>',
            "",
            f"![{caption}](../images/anim_{gif}.gif){{ .task-gif width=240 }}",
            "",
            f"**Ids** (newest first): {shown}  ",
            f"**Make:** {_make_line(env_id)}  ",
            f"**Action space** of `{env_id}`: `{_md_cell(action)}`  ",
            f"**Observation space:** `{_md_cell(observation)}`",
            "",
            "</div>",
            "",
        ]
    )
