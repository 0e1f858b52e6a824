"""FLUIDS' step rules are written once, in `fluids_bench.tasks.fluids.core` (DESIGN.md: "a rule
lives in the core or nowhere").

An `ast` scan of the faces (every module of the FLUIDS task outside `core/`, `sim/` and
`supervisor/`: the envs, the vector env, the scenario, the levels) finds code that judges a step
or computes a reward: the reward constants, comparisons against the rule options
(`reward_version`, `done_when`, `end_on_violation`), branches on the options that fail
`is_success` (`obey_lights`, `yield_to_pedestrians`), arithmetic on the reward's terms
(`failure_penalty`, route lengths and progress), tests of who a collision involves, and infos
built by hand (dicts with the info's fields: `core/infos.py` builds them). The last tests show
the scan finds each of these in a re-implementation.

A second scan (`action_code`) finds action decoding outside `core/actions.py`: arithmetic on the
car's limits or the action scales (denormalising a control, rescaling a normalised action),
clips written by hand, the supervisor's loops driven with an action (its PID, its look-ahead
points, a target speed replaced, its memory committed), a waypoint's distance, and a movement
chosen by hand (a route followed, the junction test).

A third scan (`label_code`) finds the supervisor's labels computed outside `core/labels.py`: its
plan read by hand (the routes it drew, its target speeds, its proposed controls), a movement
looked up, waypoints in an agent's frame, a label normalised.
"""

from __future__ import annotations

import ast
from pathlib import Path

import fluids_bench

FLUIDS = Path(fluids_bench.__file__).resolve().parent / "tasks" / "fluids"
# below the faces: the world (collisions and their fault labels are sim/fault.py's one rule) and
# the supervisor (its planner reads yield_to_pedestrians: how it drives, not how it is judged)
LOWER = ("core", "sim", "supervisor")
# modules that are the one home of a rule of their own
OWN_RULES = {
    "driving_score.py": "the driving score (FLUIDS-v4), one module every face calls",
}
# (module, function) pairs allowed to compare a rule option, and why
ALLOWED = {
    ("config.py", "check_failure_penalty"): "argument validation: failure_penalty needs v1",
}
CONSTANTS = {"COLLISION_PENALTY", "SUCCESS_BONUS", "VIOLATION_PENALTY"}
COMPARED = {"reward_version", "done_when", "end_on_violation"}
VALID_SETS = {"REWARD_VERSIONS", "DONE_WHEN"}  # `x in REWARD_VERSIONS`: validation
BRANCHED = {"obey_lights", "yield_to_pedestrians", "end_on_violation", "reward_version"}
ARITHMETIC = {"failure_penalty", "route_length", "_route_length", "last_s", "_last_s", "gained"}
PARTIES = {"a", "b"}  # a Collision's two agents
# the info's fields (core/infos.py builds them)
INFO_FIELDS = {
    "ego_arrived",
    "arrived",
    "route",
    "lights",
    "ego_ran_red_light",
    "ego_failed_to_yield",
}


def _name(node: ast.AST) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return None


def _names(node: ast.AST) -> set[str]:
    """Every name and attribute read anywhere in `node`."""
    return {n for sub in ast.walk(node) if (n := _name(sub)) is not None}


def _is_party(node: ast.AST) -> bool:
    if isinstance(node, ast.Attribute) and node.attr in PARTIES:
        return True
    return isinstance(node, ast.Tuple) and any(_is_party(e) for e in node.elts)


def _tested(node: ast.AST) -> ast.AST | None:
    if isinstance(node, ast.If | ast.IfExp | ast.While):
        return node.test
    if isinstance(node, ast.BoolOp):
        return node
    return None


def rule_code(source: str, filename: str) -> list[str]:
    """`filename:line: what` for each piece of judging or reward code in `source`."""
    found = []

    def report(node: ast.AST, what: str) -> None:
        found.append(f"{filename}:{node.lineno}: {what}")

    def visit(node: ast.AST, function: str | None) -> None:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            function = node.name
        allowed = (filename, function) in ALLOWED
        if isinstance(node, ast.Name | ast.Attribute) and _name(node) in CONSTANTS:
            report(node, f"reward constant {_name(node)}")
        elif isinstance(node, ast.Compare) and not allowed:
            operands = [node.left, *node.comparators]
            named = {_name(o) for o in operands}
            if named & COMPARED and not named & VALID_SETS:
                report(node, f"comparison against {sorted(named & COMPARED)[0]}")
            if any(_is_party(o) for o in operands):
                report(node, "a test of who a collision involves")
        elif isinstance(node, ast.Dict):
            keys = {k.value for k in node.keys if isinstance(k, ast.Constant)}
            if keys & INFO_FIELDS:
                report(node, f"an info built by hand ({sorted(keys & INFO_FIELDS)[0]!r})")
        elif isinstance(node, ast.BinOp) and _names(node) & ARITHMETIC:
            report(node, f"arithmetic on {sorted(_names(node) & ARITHMETIC)[0]}")
        test = _tested(node)
        if test is not None and _names(test) & BRANCHED and not allowed:
            report(node, f"a branch on {sorted(_names(test) & BRANCHED)[0]}")
        for child in ast.iter_child_nodes(node):
            visit(child, function)

    visit(ast.parse(source, filename), None)
    return sorted(set(found), key=found.index)


def face_modules() -> list[Path]:
    """The FLUIDS modules that are faces (not the core, the world or the supervisor)."""
    paths = []
    for path in sorted(FLUIDS.rglob("*.py")):
        relative = path.relative_to(FLUIDS)
        if relative.parts[0] in LOWER or relative.as_posix() in OWN_RULES:
            continue
        paths.append(path)
    return paths


def test_no_face_judges_a_step_or_computes_a_reward():
    faces = face_modules()
    assert {"env.py", "multi_agent.py", "vector/env.py", "levels.py"} <= {
        p.relative_to(FLUIDS).as_posix() for p in faces
    }
    found = []
    for path in faces:
        found += rule_code(path.read_text(encoding="utf-8"), path.relative_to(FLUIDS).as_posix())
    assert not found, "rule code outside fluids_bench/tasks/fluids/core:\n" + "\n".join(found)


def test_the_core_holds_the_rules_the_scan_looks_for():
    """The scan is not vacuous: run on the core, it finds every kind of rule code."""
    path = FLUIDS / "core" / "rules.py"
    found = "\n".join(rule_code(path.read_text(encoding="utf-8"), "rules.py"))
    for what in ("reward constant", "comparison against", "branch on", "arithmetic on"):
        assert what in found, what
    path = FLUIDS / "core" / "infos.py"
    assert "an info built by hand" in "\n".join(rule_code(path.read_text(encoding="utf-8"), "i"))


REIMPLEMENTATIONS = {
    "reward constant": "def f(x):\n    return x - COLLISION_PENALTY\n",
    "comparison against reward_version": (
        "def r(self, g):\n    if self.reward_version == 0:\n        return g\n    return 2 * g\n"
    ),
    "comparison against done_when": 'def t(self, w):\n    return self.done_when == "all"\n',
    "a branch on obey_lights": (
        "def s(self, ok):\n    return ok and not (self.obey_lights and self.faults.ran_red[0])\n"
    ),
    "arithmetic on _route_length": "def r(self, g):\n    return g / self._route_length - 1.0\n",
    "arithmetic on failure_penalty": "def p(self, n):\n    return self.failure_penalty * n\n",
    "an info built by hand ('ego_arrived')": (
        'def info(self, w):\n    return {"ego_arrived": bool(w.reached[0])}\n'
    ),
    "a test of who a collision involves": (
        "def hit(events, i):\n    return any(i in (e.a, e.b) for e in events)\n"
    ),
}


def test_a_re_implementation_in_a_new_module_is_found(tmp_path):
    """Each kind of rule code, written into a module of its own, fails the scan."""
    for what, source in REIMPLEMENTATIONS.items():
        path = tmp_path / "face.py"
        path.write_text(source, encoding="utf-8")
        found = rule_code(path.read_text(encoding="utf-8"), "face.py")
        assert any(what in line for line in found), (what, found)


# ---------------------------------------------------------------------------- action decoding
SCALES = {"max_steer", "max_force", "max_brake_force", "max_speed", "WAYPOINT_BOUND"}
# the supervisor's loops and the world's route switch, driven with an action
DRIVERS = {
    "lookahead_points", "pid_follow", "pid_follow_into", "pid_follow_worlds", "pid_controls",
    "pid_controls_into", "commit", "execute", "commit_proposals", "follow", "follow_route",
    "follow_waypoints", "hypot",
}  # fmt: skip
BOUNDS = {"low", "high", "lo", "hi"}
TARGETS = {"targets", "target_speed", "speeds"}  # the velocity plan's target speeds


def _called(node: ast.AST) -> str | None:
    return _name(node.func) if isinstance(node, ast.Call) else None


def action_code(source: str, filename: str) -> list[str]:
    """`filename:line: what` for each piece of action decoding in `source`."""
    found = []
    for node in ast.walk(ast.parse(source, filename)):
        what = None
        if isinstance(node, ast.BinOp) and _names(node) & SCALES:
            what = f"arithmetic on {sorted(_names(node) & SCALES)[0]} (an action's scale)"
        elif _called(node) == "min" and any(_called(a) == "max" for a in node.args):
            what = "a clip by hand (min of max)"
        elif _called(node) == "where" and any(
            isinstance(a, ast.Compare) and _names(a) & BOUNDS for a in node.args
        ):
            what = "a clip by hand (where against bounds)"
        elif _called(node) in DRIVERS:
            what = f"the supervisor's loops driven by hand ({_called(node)})"
        elif isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Subscript) and _name(t.value) in TARGETS for t in node.targets
        ):
            what = "a target speed replaced"
        elif isinstance(node, ast.Compare) and "enter_s" in _names(node):
            what = "a movement chosen by hand (the junction test)"
        if what is not None:
            found.append(f"{filename}:{node.lineno}: {what}")
    return sorted(set(found))


def test_no_face_decodes_an_action():
    found = []
    for path in face_modules():
        found += action_code(path.read_text(encoding="utf-8"), path.relative_to(FLUIDS).as_posix())
    assert not found, "action decoding outside fluids_bench/tasks/fluids/core:\n" + "\n".join(found)


def test_the_core_holds_the_decoding_the_scan_looks_for():
    path = FLUIDS / "core" / "actions.py"
    found = "\n".join(action_code(path.read_text(encoding="utf-8"), "actions.py"))
    for what in (
        "(an action's scale)", "a clip by hand", "driven by hand (pid_follow_into)",
        "driven by hand (follow_route)", "driven by hand (hypot)", "a target speed replaced",
        "the junction test",
    ):  # fmt: skip
        assert what in found, what


# the decoding each face had before it called the core (from the start of issue 48's item 1)
DECODING = {
    "(an action's scale)": (
        "def denormalise(world, action):\n    car = world.scene.car\n"
        "    f = action[1] * (car.max_force if action[1] >= 0 else car.max_brake_force)\n"
        "    return np.array([action[0] * car.max_steer, f])\n"
    ),
    "a clip by hand (min of max)": (
        "def clip(values, low, high):\n"
        "    return [min(max(v, lo), hi) for v, lo, hi in zip(values, low, high)]\n"
    ),
    "a clip by hand (where against bounds)": (
        "def clip(values, low, high):\n    values = np.where(low > values, low, values)\n"
        "    return np.where(high < values, high, values)\n"
    ),
    "a target speed replaced": (
        "def act(sup, w, a):\n    targets = sup.targets.copy()\n    targets[0] = float(a[0])\n"
        "    return sup.pid.controls(w, targets)\n"
    ),
    "driven by hand (lookahead_points)": (
        "def act(sup, w, aim0):\n    aim = sup.pid.lookahead_points(w)\n    aim[0] = aim0\n"
        "    return sup.pid.controls(w, sup.targets, aim)\n"
    ),
    "driven by hand (hypot)": (
        "def aim(pts, ahead):\n    return np.flatnonzero(np.hypot(*pts.T) >= ahead)\n"
    ),
    "driven by hand (commit_proposals)": "def act(sups, mask):\n    sups.commit_proposals(mask)\n",
    "driven by hand (follow_route)": (
        "def choose(envs, i, new):\n    envs[i].world.follow_route(0, int(new[i]))\n"
    ),
    "the junction test": (
        "def change(s, offset, front, routes, route):\n"
        "    return ~(s + offset + front >= routes.enter_s[route]) & (offset == 0)\n"
    ),
}


def test_a_re_implemented_decoding_is_found(tmp_path):
    """Each kind of action decoding, written into a module of its own, fails the scan."""
    for what, source in DECODING.items():
        path = tmp_path / "face.py"
        path.write_text(source, encoding="utf-8")
        found = action_code(path.read_text(encoding="utf-8"), "face.py")
        assert any(what in line for line in found), (what, found)


# ----------------------------------------------------------------------------------- labels
# the supervisor's plan, read by hand: a label's makings (core/labels.py reads them)
PLAN = {"behavior_routes", "targets", "proposed"}
# the label's maps: a movement, a waypoint in the agent's frame, a scale, a control normalised
LABELLERS = {"movement_of", "waypoints_ego_frame", "path_points", "to_normalized", "normalise"}


def label_code(source: str, filename: str) -> list[str]:
    """`filename:line: what` for each piece of a label computed in `source`."""
    found = []
    for node in ast.walk(ast.parse(source, filename)):
        what = None
        if isinstance(node, ast.Attribute) and node.attr in PLAN:
            what = f"the supervisor's plan read by hand ({node.attr})"
        elif (
            isinstance(node, ast.Subscript)
            and isinstance(node.slice, ast.Constant)
            and node.slice.value in PLAN
        ):
            what = f"the supervisor's plan read by hand ({node.slice.value})"
        elif isinstance(node, ast.Attribute) and node.attr == "of_route":
            what = "a movement looked up by hand (of_route)"
        elif _called(node) in LABELLERS:
            what = f"a label computed by hand ({_called(node)})"
        elif isinstance(node, ast.BinOp) and "waypoint_spacing" in _names(node):
            what = "a label computed by hand (arithmetic on waypoint_spacing)"
        if what is not None:
            found.append(f"{filename}:{node.lineno}: {what}")
    return sorted(set(found))


def test_no_face_computes_a_label():
    found = []
    for path in face_modules():
        found += label_code(path.read_text(encoding="utf-8"), path.relative_to(FLUIDS).as_posix())
    assert not found, "labels computed outside fluids_bench/tasks/fluids/core:\n" + "\n".join(found)


def test_the_core_holds_the_labels_the_scan_looks_for():
    path = FLUIDS / "core" / "labels.py"
    found = "\n".join(label_code(path.read_text(encoding="utf-8"), "labels.py"))
    for what in (
        "read by hand (behavior_routes)", "read by hand (targets)", "read by hand (proposed)",
        "(of_route)", "by hand (waypoints_ego_frame)", "by hand (to_normalized)",
        "by hand (normalise)", "on waypoint_spacing",
    ):  # fmt: skip
        assert what in found, what


# the labels each face computed before it called the core (from the start of issue 48's item 1:
# `levels.label`, the vector env's `label_batch`, `DrivingSupervisor.label`)
LABELLING = {
    "(behavior_routes)": (
        "def label(sups, going, movements):\n"
        '    return movements.of_route[sups.plans["behavior_routes"][going, 0]]\n'
    ),
    "(of_route)": "def label(table, routes, going):\n    return table.of_route[routes[going, 0]]\n",
    "(targets)": "def label(sup, agent):\n    return np.array([sup.targets[agent]], np.float32)\n",
    "(proposed)": (
        "def label(sup, agent):\n    steer, force = sup.proposed[agent].tolist()\n"
        "    return np.array([steer, force])\n"
    ),
    "by hand (movement_of)": "def label(w, routes, i):\n    return movement_of(w, int(routes[i]))\n",
    "by hand (to_normalized)": (
        "def label(level, world, value):\n"
        "    return actions.to_normalized(level, world, np.atleast_1d(value)).astype(np.float32)\n"
    ),
    "by hand (normalise)": "def label(car, controls):\n    return actions.normalise(car, controls)\n",
    "by hand (waypoints_ego_frame)": (
        "def label(worlds, going, first):\n"
        "    return waypoints_ego_frame(worlds, going, first.supervisor.config)\n"
    ),
    "by hand (path_points)": (
        "def label(world, s, agent, n):\n    return world.path_points(s, np.full(n, agent))[0]\n"
    ),
    "on waypoint_spacing": (
        "def ahead(worlds, mask, config):\n"
        '    return worlds["s"][mask, 0][:, None] + config.waypoint_spacing * np.arange(1, 6)\n'
    ),
}


def test_a_re_implemented_label_is_found(tmp_path):
    """Each kind of label, written into a module of its own, fails the scan."""
    for what, source in LABELLING.items():
        path = tmp_path / "face.py"
        path.write_text(source, encoding="utf-8")
        found = label_code(path.read_text(encoding="utf-8"), "face.py")
        assert any(what in line for line in found), (what, found)
