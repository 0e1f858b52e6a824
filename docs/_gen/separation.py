"""FLUIDS-v4's separation target, judged from the scorecards (`docs/results/scorecard_*.json`).

The benchmark sets FLUIDS-v4 two targets on its test split: the random policy's mean driving
score at most 0.2 x the supervisor's, and every learner separated from random by more than the
95 % intervals. Everything here is computed from the cards' intervals:

- `ratio_verdict`: met when random's whole interval lies at or below the bound's (0.2 x the
  supervisor's interval), not met when it lies wholly above, undecided when they overlap;
- `separation`: two intervals are separated only when they are disjoint;
- `predating`: which cards' FLUIDS driving scores were computed before the route-completion fix
  (`FIX_COMMIT`): whether the revision that computed a card's episodes (its provenance
  revision, or `EPISODES_FROM`'s for a card regenerated from older logged episodes) contains
  the fix (`git merge-base --is-ancestor`).

Pages call `fluids_separation()`, `fluids_separation_summary()`, `fluids_ood_ratio()` and
`driving_score_fix_note()`.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results"
TEST_SUFFIX = "_fluids_test"
FACTOR = 0.2  # the target: random's driving score at most FACTOR x the supervisor's
# The route-completion fix of fluids_bench/tasks/fluids/driving_score.py, found with
# `git log -S "world.s[agent] + world.offset[agent]" -- fluids_bench/tasks/fluids/driving_score.py`
# (the newer of the two commits: the one that removed the offset from the metres covered).
FIX_COMMIT = "cc592aba102216fdb620a596ac5e5ece32370638"
NAMES = {
    "supervisor": "supervisor",
    "random": "random",
    "bc_tree": "BC (tree)",
    "dagger_tree": "DAgger (tree)",
    "dagger_b_tree": "DAgger-B (tree)",
    "noise_tree": "noise (tree)",
    "dart_tree": "DART (tree)",
    "shiv_tree": "SHIV (tree)",
    "ppo": "PPO",
}
LEARNERS = ("bc_tree", "dagger_tree", "ppo")  # the target names these; others join if present
REFERENCES = ("random", "supervisor")

Interval = list[float]  # [point, low, high]


def number(t: Interval, digits: int = 3) -> str:
    """`point [low, high]`, minus signs typeset."""
    return f"{t[0]:.{digits}f} [{t[1]:.{digits}f}, {t[2]:.{digits}f}]".replace("-", "−")


def ratio_verdict(random: Interval, supervisor: Interval, factor: float = FACTOR) -> str:
    """`"met"`, `"not met"` or `"undecided"`: random's interval against `factor` x the
    supervisor's (met only when random's upper end is at most the bound's lower end)."""
    bound_low, bound_high = factor * supervisor[1], factor * supervisor[2]
    if random[2] <= bound_low:
        return "met"
    if random[1] > bound_high:
        return "not met"
    return "undecided"


def separation(a: Interval, b: Interval) -> str | None:
    """`"above"` or `"below"` when `a`'s interval is disjoint from `b`'s, else None."""
    if a[1] > b[2]:
        return "above"
    if a[2] < b[1]:
        return "below"
    return None


def load_cards(suffix: str = TEST_SUFFIX) -> dict[str, dict]:
    """The scorecards `scorecard_<name><suffix>.json` that hold FLUIDS, by policy name."""
    out = {}
    for path in sorted(RESULTS.glob(f"scorecard_*{suffix}.json")):
        name = path.stem[len("scorecard_") : len(path.stem) - len(suffix) or None]
        card = json.loads(path.read_text())
        if card["policy"]["name"] == name and "fluids" in card["tasks"]:
            out[name] = card
    return out


def _set(card: dict, name: str = "test") -> dict:
    return card["tasks"]["fluids"]["sets"][name]


def _label(name: str) -> str:
    return NAMES.get(name, f"`{name}`")


def _learners(cards: dict[str, dict]) -> list[str]:
    others = sorted(n for n in cards if n not in LEARNERS and n not in REFERENCES)
    return [n for n in LEARNERS if n in cards] + others


def _policy_entry(card: dict) -> dict:
    policy = card["policy"]
    return policy["tasks"]["fluids"] if policy.get("kind") == "per_task" else policy


def _budget(card: dict) -> str:
    entry = _policy_entry(card)
    if entry.get("env_steps") is not None:  # an RL run: reward, no labels
        return f"0 ({entry['env_steps']:,} env steps)"
    labels = entry.get("labels_used")
    return "–" if labels is None else f"{labels:,}"


def _successes(s: dict) -> str:
    wins = round(s["success"][0] * s["episodes"])
    return f"{wins} of {s['episodes']:,} episodes"


def table(cards: dict[str, dict]) -> str:
    """One row per policy: driving score, success, normalised score (with 95 % intervals) and
    the supervisor labels it used."""
    rows = [
        "| policy | episodes | driving score | success | normalised score | labels used |",
        "|---|---|---|---|---|---|",
    ]
    order = ["supervisor", *_learners(cards), "random"]
    for name in (n for n in order if n in cards):
        s = _set(cards[name])
        rows.append(
            f"| {_label(name)} | {s['episodes']:,} | {number(s['driving_score'])} | "
            f"{number(s['success'])} | {number(s['normalised'])} | {_budget(cards[name])} |"
        )
    return "\n".join(rows)


def ratio_text(random: dict, supervisor: dict, where: str = "") -> str:
    """The verdict on `random ≤ 0.2 × supervisor` for one set, with the intervals."""
    r, s = random["driving_score"], supervisor["driving_score"]
    verdict = ratio_verdict(r, s)
    bound = [FACTOR * v for v in s]
    why = {
        "met": "random's whole interval lies at or below the bound's",
        "not met": "random's whole interval lies above the bound's",
        "undecided": "the two intervals overlap, so the measurement neither meets nor misses "
        "the target by more than its interval",
    }[verdict]
    return (
        f"**Random ≤ {FACTOR} × supervisor{where}: {verdict}.** Random's mean driving score is "
        f"{number(r)} against a bound of {FACTOR} × {number(s)} = {number(bound)}: {why}."
    )


def learner_text(name: str, card: dict, random: dict) -> str:
    """Whether learner `name` is separated from random (driving score, the target's measure),
    with its normalised score and success beside random's."""
    s = _set(card)
    side = separation(s["driving_score"], random["driving_score"])
    verdict = f"separated from random ({side})" if side else "not separated from random"
    norm_side = separation(s["normalised"], random["normalised"])
    norm = "disjoint" if norm_side else "overlapping"
    return (
        f"**{_label(name)}: {verdict}** on the driving score, {number(s['driving_score'])} "
        f"against {number(random['driving_score'])}; normalised score {number(s['normalised'])} "
        f"against {number(random['normalised'])} ({norm}); success "
        f"{number(s['success'])} ({_successes(s)})."
    )


def pair_text(a: str, b: str, cards: dict[str, dict]) -> str:
    """Learner `a` against learner `b` on the normalised score and the driving score."""
    sa, sb = _set(cards[a]), _set(cards[b])
    parts = []
    for key, what in (("normalised", "normalised score"), ("driving_score", "driving score")):
        side = separation(sa[key], sb[key])
        verdict = f"separated {side}" if side else "not separated"
        parts.append(f"{what} {number(sa[key])} against {number(sb[key])}: {verdict}")
    return f"{_label(a)} against {_label(b)}: " + "; ".join(parts) + "."


def fluids_separation(suffix: str = TEST_SUFFIX) -> str:
    """The separation table and the verdicts, from `scorecard_*<suffix>.json`."""
    cards = load_cards(suffix)
    missing = [r for r in REFERENCES if r not in cards]
    if missing:
        return f"*No FLUIDS reference scorecard `scorecard_{missing[0]}{suffix}.json` yet.*"
    random, supervisor = _set(cards["random"]), _set(cards["supervisor"])
    out = [table(cards), "", f"- {ratio_text(random, supervisor)}"]
    learners = _learners(cards)
    for name in learners:
        out.append(f"- {learner_text(name, cards[name], random)}")
    for name in (n for n in LEARNERS if n not in cards):
        out.append(
            f"- **{_label(name)}: no scorecard** (`scorecard_{name}{suffix}.json`), so not "
            "measured."
        )
    pairs = [(b, a) for i, a in enumerate(learners) for b in learners[i + 1 :]]
    if pairs:
        out += ["", "The learners against each other (intervals disjoint or not):", ""]
        out += [f"- {pair_text(a, b, cards)}" for a, b in pairs]
    return "\n".join(out)


def fluids_separation_summary(suffix: str = TEST_SUFFIX) -> str:
    """One paragraph for other pages: the verdicts with their numbers."""
    cards = load_cards(suffix)
    if any(r not in cards for r in REFERENCES):
        return "*The FLUIDS-v4 test-split scorecards are not there yet.*"
    random, supervisor = _set(cards["random"]), _set(cards["supervisor"])
    r, s = random["driving_score"], supervisor["driving_score"]
    text = (
        f"On all {random['episodes']:,} episodes of the test split (the "
        f"[leaderboard](../leaderboard.md#fluids-the-separation-target)), random's mean driving "
        f"score is {number(r)} against the supervisor's {number(s)}: the target of at most "
        f"{FACTOR} × the supervisor's is {ratio_verdict(r, s)}."
    )
    for name in _learners(cards):
        d = _set(cards[name])["driving_score"]
        side = separation(d, r)
        verdict = f"separated from random ({side})" if side else "not separated from random"
        text += f" {_label(name)} scores {number(d)}: {verdict}."
    for name in (n for n in LEARNERS if n not in cards):
        text += f" {_label(name)} has no scorecard yet."
    return text


def fluids_ood_ratio(suffix: str = "") -> str:
    """The ratio target on every FLUIDS set of the full-suite reference cards."""
    cards = load_cards(suffix)
    if any(r not in cards for r in REFERENCES):
        return "*No full-suite FLUIDS reference scorecards yet.*"
    sets = cards["random"]["tasks"]["fluids"]["sets"]
    lines = []
    for name in sets:
        where = " on the test split" if name == "test" else f" on `{name}`"
        lines.append(
            f"- {ratio_text(_set(cards['random'], name), _set(cards['supervisor'], name), where)}"
        )
    return "\n".join(lines)


# --- which cards' FLUIDS driving scores predate the route-completion fix ---------------------

# Cards regenerated from episodes logged at an earlier revision than the one they record (the
# evaluator reuses logged episodes): the revision that computed their FLUIDS episodes. Checked
# against git by tests/docs/test_separation.py (the provenance revision of the card's oldest
# committed version with the same FLUIDS driving scores).
EPISODES_FROM: dict[str, str] = {}  # none now: the neural cards' FLUIDS episodes were rerun


def _git(*args: str) -> subprocess.CompletedProcess | None:
    try:
        return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)
    except OSError:
        return None


def _fluids_driving(card: dict) -> dict | None:
    task = card.get("tasks", {}).get("fluids")
    if task is None:
        return None
    return {name: s.get("driving_score") for name, s in task["sets"].items()}


def card_revision(path: Path) -> str | None:
    """The revision whose code computed the FLUIDS episodes of the card at `path`: its
    provenance revision, or `EPISODES_FROM`'s for a card regenerated from older episodes."""
    if path.name in EPISODES_FROM:
        return EPISODES_FROM[path.name]
    return json.loads(path.read_text())["provenance"]["git_revision"]


def oldest_same(path: Path) -> str | None:
    """The provenance revision of the oldest committed version of the card at `path` (in an
    unbroken line back from now) whose FLUIDS driving scores are the current ones; None
    without git history."""
    current = _fluids_driving(json.loads(path.read_text()))
    relative = path.relative_to(ROOT).as_posix()
    log = _git("log", "--format=%H", "--", relative)
    if log is None or log.returncode != 0 or not log.stdout.split():
        return None
    revision = None
    for commit in log.stdout.split():
        shown = _git("show", f"{commit}:{relative}")
        if shown is None or shown.returncode != 0:
            break
        try:
            old = json.loads(shown.stdout)
        except json.JSONDecodeError:
            break
        if _fluids_driving(old) != current:
            break
        revision = old.get("provenance", {}).get("git_revision") or revision
    return revision


def predates(revision: str | None, fix: str = FIX_COMMIT) -> bool | None:
    """Whether `revision` lacks the fix (True), has it (False), or git cannot tell (None)."""
    if not revision:
        return None
    done = _git("merge-base", "--is-ancestor", fix, revision.removesuffix("-dirty"))
    if done is None or done.returncode not in (0, 1):
        return None
    return done.returncode == 1


def predating() -> dict[str, list[tuple[str, str | None]]]:
    """The FLUIDS cards by verdict: `"before"` the fix, `"after"` it, `"unchanged"` (after it,
    with the same FLUIDS driving scores as a version of the card computed before it) and
    `"unknown"` (git cannot tell); each entry `(file, revision)`."""
    out: dict[str, list[tuple[str, str | None]]] = {
        "before": [], "after": [], "unchanged": [], "unknown": []
    }  # fmt: skip
    for path in sorted(RESULTS.glob("scorecard_*.json")):
        if _fluids_driving(json.loads(path.read_text())) is None:
            continue
        revision = card_revision(path)
        verdict = predates(revision)
        key = {True: "before", False: "after", None: "unknown"}[verdict]
        if key == "after" and predates(oldest_same(path)):
            key = "unchanged"
        out[key].append((path.name, revision))
    return out


def _files(entries: list[tuple[str, str | None]]) -> str:
    return ", ".join(f"`{name}` ({(rev or 'no revision')[:10]})" for name, rev in entries)


def driving_score_fix_note() -> str:
    """Which scorecards' FLUIDS driving scores were computed before the fix (computed)."""
    groups = predating()
    lines = []
    if groups["before"]:
        lines.append(
            "**Computed before the fix** (an episode planned back to its route may score too "
            "high there): " + _files(groups["before"]) + "."
        )
    else:
        lines.append("No scorecard's FLUIDS driving scores predate the fix.")
    if groups["after"] or groups["unchanged"]:
        lines.append(
            "**Computed with the fix**: " + _files(groups["after"] + groups["unchanged"]) + "."
        )
    if groups["unchanged"]:
        lines.append(
            "Of these, the FLUIDS driving scores of "
            + ", ".join(f"`{name}`" for name, _ in groups["unchanged"])
            + " are the same (means and intervals) as those of their versions computed before "
            "the fix."
        )
    if groups["unknown"]:
        lines.append(
            "**Not determined here** (git does not know the revision): "
            + _files(groups["unknown"])
            + "."
        )
    return "\n\n".join(lines)
