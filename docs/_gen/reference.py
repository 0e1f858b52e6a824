"""Reference material generated from the code: env cards, ids, keyword arguments, spaces, CLI.

Used by the site's macros (`docs/_gen/macros.py`) and by the docs tests, so a page cannot say
something the code does not. Nothing here is hand-copied: the ids come from
`fluids_bench.registration`, the arguments from each entry point's signature and their
descriptions from its `__init__`'s `Args:` (FLUIDS': `FluidsConfig`'s field docs), what a
value may be from the entry point's own validation (it is called with a value no check accepts
and the `allowed:` part of its error is shown), the spaces from the built env.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import inspect
import io
import re
import textwrap
import warnings
from dataclasses import dataclass, field
from functools import cache

import gymnasium as gym
import numpy as np

import fluids_bench  # noqa: F401  (registers every id)
from fluids_bench.core.docstrings import section_entries
from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS

_VERSION = re.compile(r"-v(\d+)$")


def _version(env_id: str) -> int:
    m = _VERSION.search(env_id)
    return int(m.group(1)) if m else -1


def _module_of(env_id: str) -> str:
    """The module of the id's entry point (`package.module` of `package.module:Name`)."""
    target = ENV_SPECS[env_id][0] if env_id in ENV_SPECS else PARALLEL_ENV_SPECS[env_id][0]
    return target.partition(":")[0]


@dataclass(frozen=True)
class Family:
    """One page of the site: a task family, its picture and the entry-point module(s) whose
    registered ids are its ids (read from the registry, so a new id appears by itself)."""

    slug: str
    title: str
    modules: tuple[str, ...]  # every Gymnasium / PettingZoo id whose entry point lives here
    image: str = ""  # one frame of the env, written by scripts/figures/make_task_gifs.py
    blurb: str = ""
    extra: dict = field(default_factory=dict)

    def _registered(self, specs: dict) -> tuple[str, ...]:
        ids = [i for i in specs if _module_of(i) in self.modules]
        order = {env_id: n for n, env_id in enumerate(specs)}
        return tuple(sorted(ids, key=lambda i: (-_version(i), order[i])))  # newest first

    @property
    def ids(self) -> tuple[str, ...]:
        """The family's Gymnasium ids, newest version first, then in the registry's order."""
        return self._registered(ENV_SPECS)

    @property
    def parallel_ids(self) -> tuple[str, ...]:
        """The family's PettingZoo ids, newest version first."""
        return self._registered(PARALLEL_ENV_SPECS)


_TASKS = "fluids_bench.tasks."
FAMILIES: tuple[Family, ...] = (
    Family(
        "fluids",
        "FLUIDS",
        (_TASKS + "fluids.env",),
        image="images/thumb_fluids.png",
        blurb="an urban intersection: kinematic cars, pedestrians, lights; four-level supervisor",
    ),
    Family(
        "fluids-multi-agent",
        "FLUIDS multi-agent",
        (_TASKS + "fluids.multi_agent",),
        image="images/thumb_fluids-multi-agent.png",
        blurb="PettingZoo ParallelEnv: every controlled car is an agent with its own label",
    ),
    Family(
        "gridworld",
        "GridWorld",
        (_TASKS + "gridworld.env",),
        image="images/thumb_gridworld.png",
        blurb="ch. 3: a 15×15 stochastic gridworld with an exact value-iteration supervisor",
    ),
    Family(
        "dag",
        "DAG",
        (_TASKS + "dag.env",),
        image="images/thumb_dag.png",
        blurb="ch. 4: the three-level decision DAG of Theorem 1 and its greedy supervisor",
    ),
    Family(
        "singulation",
        "Singulation",
        (_TASKS + "singulation.env",),
        image="images/thumb_singulation.png",
        blurb="ch. 5: a planar arm separates one of four touching objects (pymunk)",
    ),
    Family(
        "grasping",
        "Grasping in clutter",
        (_TASKS + "grasping.env",),
        image="images/thumb_grasping.png",
        blurb="ch. 6: a 3-joint arm grasps a target among five obstacles (pymunk)",
    ),
    Family(
        "track",
        "DrivingTrack",
        (_TASKS + "track.env",),
        image="images/thumb_track.png",
        blurb="ch. 6: a car on a random polygonal track, seen through HOG features",
    ),
    Family(
        "locomotion",
        "MuJoCo locomotion",
        (_TASKS + "locomotion.env",),
        image="images/thumb_locomotion.png",
        blurb="ch. 3: Gymnasium's MuJoCo v5 envs, unchanged, with shipped supervisors",
    ),
)


def family(slug: str) -> Family:
    for f in FAMILIES:
        if f.slug == slug:
            return f
    raise ValueError(f"family is {slug!r}; allowed: {[f.slug for f in FAMILIES]}")


def family_of(env_id: str) -> Family:
    """The family whose page shows `env_id`; an id of no family is an error, not a gap."""
    owners = [f for f in FAMILIES if env_id in f.ids + f.parallel_ids]
    if len(owners) != 1:
        raise ValueError(
            f"{env_id} (entry point in {_module_of(env_id)}) belongs to {len(owners)} families; "
            "give its module to exactly one Family in docs/_gen/reference.py"
        )
    return owners[0]


def all_ids() -> list[str]:
    """Every registered id, Gymnasium's then PettingZoo's, in the registry's order."""
    return [*ENV_SPECS, *PARALLEL_ENV_SPECS]


def _entry_point(env_id: str):
    """The class or factory behind an id, and the id's registered keyword arguments."""
    if env_id in ENV_SPECS:
        target, _, kwargs = ENV_SPECS[env_id]
    elif env_id in PARALLEL_ENV_SPECS:
        target, kwargs = PARALLEL_ENV_SPECS[env_id]
    else:
        raise ValueError(
            f"env id is {env_id!r}; allowed: {sorted(ENV_SPECS) + sorted(PARALLEL_ENV_SPECS)}"
        )
    module, _, name = target.partition(":")
    return getattr(importlib.import_module(module), name), dict(kwargs)


def _card_owner(env_id: str):
    """The class whose docstring is the env card (a factory's env class for PettingZoo ids)."""
    obj, _ = _entry_point(env_id)
    if inspect.isclass(obj):
        return obj
    module = importlib.import_module(obj.__module__)
    classes = [
        c
        for c in vars(module).values()
        if inspect.isclass(c)
        and c.__module__ == module.__name__
        and "## Description" in (c.__doc__ or "")
    ]
    if len(classes) != 1:
        raise RuntimeError(f"{env_id}: expected one env card class in {module.__name__}")
    return classes[0]


def _signature_params(env_id: str) -> list[inspect.Parameter]:
    # a factory taking only **kwargs passes them on to the env class: read that class's
    target = _card_owner(env_id).__init__
    params = list(inspect.signature(target).parameters.values())
    return [
        p
        for p in params
        if p.name != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
    ]


class _Unacceptable:
    """A value no argument check accepts: its error message says what is allowed."""

    def __repr__(self) -> str:
        return "<probe>"

    def __iter__(self):  # so an argument that iterates its value fails in its check, not here
        raise TypeError("probe")


@cache
def allowed_values(env_id: str) -> dict[str, str]:
    """For every keyword argument of `env_id`'s entry point: what its validation allows, read
    from the `ValueError` it raises for a value nothing accepts ("not checked" if it takes it)."""
    obj, registered = _entry_point(env_id)
    out: dict[str, str] = {}
    for p in _signature_params(env_id):
        kwargs = {**registered, p.name: _Unacceptable()}
        try:
            with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
                warnings.simplefilter("ignore")
                env = obj(**kwargs)
            with contextlib.suppress(Exception):
                env.close()
            out[p.name] = "not checked"
        except ValueError as exc:
            match = re.search(r"allowed: (.*)", str(exc), flags=re.S)
            out[p.name] = match.group(1).strip() if match else str(exc)
        except Exception as exc:  # noqa: BLE001  (shown as a defect on the page, not hidden)
            out[p.name] = f"not checked ({type(exc).__name__})"
    return out


def _card_text(env_id: str) -> str:
    doc = inspect.getdoc(_card_owner(env_id)) or ""
    return textwrap.dedent(doc).strip()


def card_sections(env_id: str) -> dict[str, str]:
    """The env card's sections (`## Name` → body), in order."""
    sections: dict[str, str] = {}
    name = "Summary"
    lines: list[str] = []
    for line in _card_text(env_id).splitlines():
        m = re.match(r"^## (.+?)\s*$", line)
        if m:
            sections[name] = "\n".join(lines).strip()
            name, lines = m.group(1), []
        else:
            lines.append(line)
    sections[name] = "\n".join(lines).strip()
    return {k: v for k, v in sections.items() if v}


def argument_docs(env_id: str) -> dict[str, str]:
    """Each keyword argument's description: its entry in the `Args:` section of the entry
    point's `__init__` docstring (Google style). The FLUIDS envs' list every option of
    `FluidsConfig` there, from the config's own field docs."""
    init = _card_owner(env_id).__init__
    return section_entries(inspect.getdoc(init), "Args")


def undocumented_arguments(env_id: str) -> list[str]:
    """The keyword arguments of `env_id` without a description (none, for every id)."""
    docs = argument_docs(env_id)
    return [p.name for p in _signature_params(env_id) if not docs.get(p.name, "").strip()]


def _md_cell(text: object) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def kwargs_table(env_id: str) -> str:
    """Every keyword argument: the signature's default, the id's registered value, what the
    validation allows, and its description (`argument_docs`)."""
    _, registered = _entry_point(env_id)
    allowed = allowed_values(env_id)
    notes = argument_docs(env_id)
    rows = ["| argument | default | allowed | description |", "|---|---|---|---|"]
    for p in _signature_params(env_id):
        default = repr(registered[p.name]) if p.name in registered else repr(p.default)
        if p.name in registered:
            default = f"**{default}** (registered; signature: {p.default!r})"
        rows.append(
            f"| `{p.name}` | {_md_cell(default)} | {_md_cell(allowed[p.name])} "
            f"| {_md_cell(notes.get(p.name, ''))} |"
        )
    return "\n".join(rows)


def env_card(env_id: str, level: int = 3) -> str:
    """The env card as Markdown, headings at `level`; its hand-written Arguments table is
    replaced by `kwargs_table` (one source of truth: the code)."""
    parts = []
    for name, body in card_sections(env_id).items():
        if name == "Summary":
            parts.append(body)
            continue
        parts.append("#" * level + " " + name)
        parts.append(kwargs_table(env_id) if name == "Arguments" else body)
    if "Arguments" not in card_sections(env_id):
        parts += ["#" * level + " Arguments", kwargs_table(env_id)]
    return "\n\n".join(parts)


def ids_table(slug: str) -> str:
    """Every id of a family: how it is made, its step limit and its registered kwargs."""
    f = family(slug)
    rows = ["| id | made with | step limit | registered kwargs |", "|---|---|---|---|"]
    for env_id in f.ids:
        _, steps, kwargs = ENV_SPECS[env_id]
        rows.append(f"| `{env_id}` | `gym.make` | {steps} | {_kwargs_text(kwargs)} |")
    for env_id in f.parallel_ids:
        _, kwargs = PARALLEL_ENV_SPECS[env_id]
        rows.append(
            f'| `{env_id}` | `pettingzoo.make("parallel", …)` | `max_cycles` | {_kwargs_text(kwargs)} |'
        )
    return "\n".join(rows)


def _kwargs_text(kwargs: dict) -> str:
    return ", ".join(f"`{k}={v!r}`" for k, v in kwargs.items()) or "(defaults)"


def _space_text(space) -> str:
    """`str(space)`, except that a Box whose bounds vary per element (the quasi-LIDAR's rows)
    shows one row of bounds instead of the whole array."""
    if (
        isinstance(space, gym.spaces.Box)
        and space.shape
        and (np.ptp(space.low) > 0 or np.ptp(space.high) > 0)
    ):
        low = space.low.reshape(-1, space.shape[-1])
        high = space.high.reshape(-1, space.shape[-1])
        if (low == low[0]).all() and (high == high[0]).all() and len(space.shape) > 1:
            lo = ", ".join(f"{v:g}" for v in low[0])
            hi = ", ".join(f"{v:g}" for v in high[0])
            return f"Box(low=[{lo}], high=[{hi}] per row, {space.shape}, {space.dtype})"
        return f"Box(bounds per element, {space.shape}, {space.dtype})"
    if isinstance(space, gym.spaces.Dict):
        inner = ", ".join(f"{k!r}: {_space_text(v)}" for k, v in space.spaces.items())
        return f"Dict({inner})"
    return str(space)


@cache
def _spaces(env_id: str) -> tuple[str, str]:
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        if env_id in ENV_SPECS:
            env = gym.make(env_id)
            spaces = (_space_text(env.action_space), _space_text(env.observation_space))
        else:
            from fluids_bench.registration import make_parallel_env

            env = make_parallel_env(env_id)
            agent = env.possible_agents[0]
            spaces = (
                f"per agent: {_space_text(env.action_space(agent))}",
                f"per agent: {_space_text(env.observation_space(agent))}",
            )
        env.close()
    return spaces


def spaces_table(slug: str) -> str:
    """The action and observation space of every id of a family, as built."""
    f = family(slug)
    rows = ["| id | action space | observation space |", "|---|---|---|"]
    for env_id in f.ids + f.parallel_ids:
        action, observation = _spaces(env_id)
        rows.append(f"| `{env_id}` | `{_md_cell(action)}` | `{_md_cell(observation)}` |")
    return "\n".join(rows)


def _family_ids(f: Family) -> tuple[str, ...]:
    return f.ids + f.parallel_ids


def _check_every_id_has_a_family() -> None:
    for env_id in all_ids():
        family_of(env_id)  # raises for an id no page would show


def _tasks_table(picture, link_root: str) -> str:
    """The families side by side: `picture(family)` (the cell's image markup), ids (every
    registered id, newest first) and one line, pages linked under `link_root`."""
    _check_every_id_has_a_family()
    rows = ["| | family | ids |", "|---|---|---|"]
    for f in FAMILIES:
        ids = ", ".join(f"`{i}`" for i in _family_ids(f))
        rows.append(f"| {picture(f)} | [{f.title}]({link_root}{f.slug}.md): {f.blurb} | {ids} |")
    return "\n".join(rows)


def gallery(root: str = "") -> str:
    """The families side by side on a docs page. `root`: the docs root relative to the calling
    page ("" top level, "../" one folder down)."""
    return _tasks_table(
        lambda f: f"![{f.title}]({root}{f.image}){{ .thumb width=160 }}", f"{root}tasks/"
    )


def readme_tasks_table() -> str:
    """The README's task table (GitHub renders no macros: tests/docs check that the README holds
    exactly this; `python docs/_gen/reference.py --readme` prints it)."""
    return _tasks_table(lambda f: f'<img src="docs/{f.image}" width="140">', "docs/tasks/")


def registry_table(root: str = "") -> str:
    """Every registered id in one table: its family page, how it is made, its step limit and
    registered kwargs, in the registry's order."""
    rows = ["| id | family | made with | step limit | registered kwargs |", "|---|---|---|---|---|"]
    for env_id in all_ids():
        f = family_of(env_id)
        link = f"[{f.title}]({root}tasks/{f.slug}.md)"
        if env_id in ENV_SPECS:
            _, steps, kwargs = ENV_SPECS[env_id]
            made = "`gym.make`"
        else:
            _, kwargs = PARALLEL_ENV_SPECS[env_id]
            made, steps = '`pettingzoo.make("parallel", …)`', "`max_cycles`"
        rows.append(f"| `{env_id}` | {link} | {made} | {steps} | {_kwargs_text(kwargs)} |")
    return "\n".join(rows)


# What each kind of user should make; every id named here must be registered (checked when the
# page is built). The benchmark's ids come from fluids_bench.benchmark's suite where it exists.
ID_USES: tuple[tuple[str, tuple[str, ...], str], ...] = (
    (
        "train an off-the-shelf RL agent on FLUIDS (actions and observations in [-1, 1], a reward "
        "that agrees with success, failures weighted 3)",
        ("FLUIDS-v3", "FLUIDS-Sensitivity-v3", "FLUIDS-MultiAgent-v3"),
        "tasks/fluids-rl.md",
    ),
    (
        "compare imitation learners on FLUIDS in physical units (defensive background drivers, "
        "success that requires obeying lights and yielding)",
        ("FLUIDS-v1", "FLUIDS-Sensitivity-v1", "FLUIDS-MultiAgent-v1"),
        "tasks/fluids-v1.md",
    ),
    (
        "reproduce the source's FLUIDS experiments (its setting, kept unchanged)",
        ("FLUIDS-v0", "FLUIDS-Sensitivity-v0", "FLUIDS-MultiAgent-v0"),
        "reproductions/fig-7-6.md",
    ),
    (
        "reproduce the source's track experiments with its crash-prone supervisor",
        ("DrivingTrack-Source-v0",),
        "reproductions/fig-6-3.md",
    ),
)


def _benchmark_ids() -> list[str]:
    try:
        from fluids_bench.benchmark import SUITE
    except ImportError:  # the suite is not part of this version
        return []
    return [t.env_id for t in SUITE.tasks]


def _newest() -> list[str]:
    """The newest version of every id name (the id less its `-vN`), in the registry's order."""
    newest: dict[str, str] = {}
    for env_id in all_ids():
        name = _VERSION.sub("", env_id)
        if name not in newest or _version(env_id) > _version(newest[name]):
            newest[name] = env_id
    return list(newest.values())


def id_guide(root: str = "") -> str:
    """Which id to use for what: the uses above, the benchmark's ids, and the newest version of
    every id (for anything else)."""
    registered = set(all_ids())
    rows = ["| to … | make | see |", "|---|---|---|"]
    bench = _benchmark_ids()
    if bench:
        rows.append(
            "| evaluate a learner on the benchmark (seed splits, OOD sets, scorecards) | "
            + ", ".join(f"`{i}`" for i in dict.fromkeys(bench))
            + f" | [Benchmarks]({root}benchmarks/index.md) |"
        )
    for use, ids, page in ID_USES:
        unknown = [i for i in ids if i not in registered]
        if unknown:
            raise ValueError(
                f"ID_USES names unregistered ids {unknown}; allowed: {sorted(registered)}"
            )
        named = ", ".join(f"`{i}`" for i in ids)
        rows.append(f"| {use} | {named} | [{page.rsplit('/', 1)[-1][:-3]}]({root}{page}) |")
    newest = ", ".join(f"`{i}`" for i in _newest())
    rows.append(
        f"| anything else: the newest version of each id | {newest} "
        f"| [Versioning]({root}versioning.md) |"
    )
    return "\n".join(rows)


def cli_reference() -> str:
    """Every `fluids-bench` subcommand's `--help`, as argparse prints it."""
    from fluids_bench.cli import build_parser

    parser = build_parser()
    parts = ["## fluids-bench", "```text", _help(parser), "```"]
    for action in parser._actions:  # noqa: SLF001  (argparse keeps its subparsers here)
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            for name, sub in action.choices.items():
                parts += [f"## fluids-bench {name}", "```text", _help(sub), "```"]
    return "\n\n".join(parts)


def _help(parser: argparse.ArgumentParser) -> str:
    import os

    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "80"  # the same wrapping wherever the docs are built; fits the column
    try:
        return parser.format_help().rstrip()
    finally:
        if old is None:
            os.environ.pop("COLUMNS")
        else:
            os.environ["COLUMNS"] = old


if __name__ == "__main__":
    import sys

    if sys.argv[1:] != ["--readme"]:
        raise SystemExit("usage: python docs/_gen/reference.py --readme")
    print(readme_tasks_table())
