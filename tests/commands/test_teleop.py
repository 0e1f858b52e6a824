"""``fluids-bench teleop``: real pygame windows (SDL's dummy driver), input posted as events."""

from __future__ import annotations

import functools
import json
import math
import sys

import minari
import numpy as np
import pytest

pygame = pytest.importorskip("pygame")

from fluids_bench.algos.policies import PolicySpec  # noqa: E402
from fluids_bench.cli import main  # noqa: E402
from fluids_bench.human import session  # noqa: E402
from fluids_bench.human.offline import evaluate, fit, load_pairs  # noqa: E402

FAST = ["--fps", "1000"]  # step as fast as the window loop runs


@pytest.fixture(autouse=True)
def datasets_root(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("FLUIDS_BENCH_HEADLESS", "1")  # windows without a screen, events posted


def key(k, down=True):
    return pygame.event.Event(pygame.KEYDOWN if down else pygame.KEYUP, key=k)


def per_step(plan):
    """A session script posting ``plan(episode, t)`` (a list of events) once per step."""
    posted = set()

    def script(s):
        if s.current is None:
            return
        where = (len(s.finished), len(s.current.actions))
        if where not in posted:
            posted.add(where)
            for event in plan(*where):
                if isinstance(event, BaseException):
                    raise event
                if event == "stop":
                    s.stop = True
                    return
                pygame.event.post(event)

    return script


def run_teleop(monkeypatch, argv, plan):
    monkeypatch.setattr(session, "Teleop", functools.partial(session.Teleop, script=per_step(plan)))
    return main(["teleop", *argv])


ARROWS = [pygame.K_LEFT, pygame.K_UP, pygame.K_RIGHT, pygame.K_DOWN]


def arrows(episode, t):
    k = ARROWS[t % 4]
    previous = ARROWS[(t - 1) % 4]
    return [key(previous, False), key(k)]


def test_gridworld_session_records_a_dataset_minari_loads_and_bc_learns(monkeypatch, capsys):
    argv = ["--env", "GridWorld-v0", "--dataset", "tt/grid-v0", "--episodes", "2", *FAST]
    argv += ["--snapshot-every", "1"]
    assert run_teleop(monkeypatch, argv, arrows) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary == {**summary, "episodes": 2, "steps": 60, "ended": "done"}
    data = minari.load_dataset("tt/grid-v0")
    assert data.total_episodes == 2 and data.spec.env_spec.id == "GridWorld-v0"
    ep = data[1]
    expected = [[0, 2, 1, 3][t % 4] for t in range(30)]  # left, up (forward), right, down
    assert ep.actions.tolist() == expected
    assert ep.infos["executed_action"][1:].tolist() == expected
    assert ep.infos["provenance"][0] == "reset" and set(ep.infos["provenance"][1:]) == {"human"}
    assert np.all(np.diff(ep.infos["time"][1:]) >= 0)
    assert np.all(ep.infos["reaction_time"][1:] >= 0)  # a key went down while each state showed
    assert ep.infos["state_stored"].all()
    seeds = [m["seed"] for m in data.storage.get_episode_metadata([0, 1])]
    assert seeds == [0, 1]
    # the supervisor's labels of the same states sit next to the person's actions
    env = data.recover_environment()
    env.reset(seed=1)
    assert ep.infos["supervisor_action"][1] == env.unwrapped.supervisor_action()
    # BC on the teleop data: a tree reproduces the person's (state-determined) moves
    x, y = load_pairs(["tt/grid-v0"])
    assert x.shape == (60, 2) and len(y) == 60
    policy = fit(["tt/grid-v0"], env, PolicySpec("tree"))
    assert set(policy.predict(x).tolist()) <= {0, 1, 2, 3}
    assert "mean_return" in evaluate(policy, env, 2, seed=5)


def test_track_left_straight_right(monkeypatch, capsys):
    plan = {0: pygame.K_LEFT, 1: pygame.K_UP, 2: pygame.K_RIGHT}

    def turns(episode, t):
        return [key(plan[(t - 1) % 3], False), key(plan[t % 3])]

    argv = ["--env", "DrivingTrack-v0", "--dataset", "tt/track-v0", "--max-steps", "6", *FAST]
    assert run_teleop(monkeypatch, argv, turns) == 0
    assert minari.load_dataset("tt/track-v0")[0].actions.tolist() == [2, 1, 0, 2, 1, 0]


def test_fluids_keyboard_and_virtual_joystick(monkeypatch, capsys):
    def drive(episode, t):
        if t == 0:
            return [key(pygame.K_UP), key(pygame.K_LEFT)]
        if t == 2:  # release the keys, push the stick right and down (brake)
            return [
                key(pygame.K_UP, False),
                key(pygame.K_LEFT, False),
                pygame.event.Event(pygame.JOYAXISMOTION, joy=0, instance_id=0, axis=0, value=0.5),
                pygame.event.Event(pygame.JOYAXISMOTION, joy=0, instance_id=0, axis=1, value=0.25),
            ]
        return []

    argv = ["--env", "FLUIDS-v1", "--env-kwarg", "num_pedestrians=0", "--env-kwarg", "num_cars=2"]
    argv += ["--dataset", "tt/fluids-v0", "--max-steps", "4", "--show-label", *FAST]
    assert run_teleop(monkeypatch, argv, drive) == 0
    actions = minari.load_dataset("tt/fluids-v0")[0].actions
    np.testing.assert_allclose(actions, [[0.5, 1], [0.5, 1], [-0.5, -0.25], [-0.5, -0.25]])


def test_fluids_velocity_level_target_speed(monkeypatch, capsys):
    def speed(episode, t):
        return {
            0: [key(pygame.K_UP)],
            1: [key(pygame.K_UP, False), key(pygame.K_UP)],
            2: [key(pygame.K_9)],
        }.get(t, [])

    argv = ["--env", "FLUIDS-v1", "--env-kwarg", "action_level=velocity"]
    argv += ["--env-kwarg", "num_pedestrians=0", "--env-kwarg", "num_cars=2"]
    argv += ["--dataset", "tt/vel-v0", "--max-steps", "3", *FAST]
    assert run_teleop(monkeypatch, argv, speed) == 0
    actions = minari.load_dataset("tt/vel-v0")[0].actions.reshape(-1)
    assert actions[:2].tolist() == [1.0, 2.0] and actions[2] > 2.0


def _mouse(button, pos, down=True):
    kind = pygame.MOUSEBUTTONDOWN if down else pygame.MOUSEBUTTONUP
    return pygame.event.Event(kind, button=button, pos=pos)


def test_singulation_mouse_with_fixed_noise(monkeypatch, capsys):
    def drag(episode, t):
        if t == 0:
            return [_mouse(1, (300, 100))]  # right of and beyond the tip
        if t == 3:
            return [_mouse(1, (300, 100), down=False)]
        return [
            pygame.event.Event(
                pygame.MOUSEMOTION, pos=(300, 100 + t), rel=(0, 1), buttons=(1, 0, 0)
            )
        ]

    argv = ["--env", "Singulation-v0", "--dataset", "tt/sing-v0", "--max-steps", "5"]
    argv += ["--noise", "0.3", "--snapshot-every", "2", *FAST]
    assert run_teleop(monkeypatch, argv, drag) == 0
    ep = minari.load_dataset("tt/sing-v0")[0]
    a = ep.actions
    assert a[0, 0] == -1.0 and a[0, 1] == 1.0  # rotate clockwise (toward +x) and extend
    assert a[3:].tolist() == [[0.0, 0.0], [0.0, 0.0]]  # button released: hold still
    executed = ep.infos["executed_action"][1:]
    assert not np.allclose(executed, a)  # the noise went into the executed action only
    assert set(ep.infos["provenance"][1:]) == {"human_noise"}
    assert ep.infos["noise_level"][1] == pytest.approx(2 * 0.3**2)
    assert ep.infos["state_stored"].tolist() == [True, False, True, False, True, False]


def test_grasping_mouse_moves_and_closes(monkeypatch, capsys):
    def grab(episode, t):
        return {0: [_mouse(1, (240, 120))], 2: [_mouse(3, (240, 120))]}.get(t, [])

    argv = ["--env", "GraspingInClutter-v0", "--dataset", "tt/grasp-v0", "--max-steps", "3", *FAST]
    assert run_teleop(monkeypatch, argv, grab) == 0
    a = minari.load_dataset("tt/grasp-v0")[0].actions
    assert a[0, 1] > 0.9 and a[0, 2] == 0.0  # up the picture = away from the base (+y)
    assert a[2, 2] == 1.0  # right button held: jaws close


def test_append_only_when_asked_and_dart_noise(monkeypatch, capsys):
    argv = ["--env", "GridWorld-v0", "--dataset", "tt/g-v0", "--max-steps", "6", *FAST]
    assert run_teleop(monkeypatch, [*argv, "--episodes", "3", "--noise", "dart"], arrows) == 0
    levels = [ep.infos["noise_level"][1] for ep in minari.load_dataset("tt/g-v0")]
    assert levels[:2] == [0.0, 0.0]  # estimated after the second episode
    assert run_teleop(monkeypatch, argv, arrows) == 2
    assert "pass --append" in capsys.readouterr().err
    assert run_teleop(monkeypatch, [*argv, "--append"], arrows) == 0
    data = minari.load_dataset("tt/g-v0")
    assert data.total_episodes == 4
    assert [m["seed"] for m in data.storage.get_episode_metadata(range(4))] == [0, 1, 2, 3]


def test_closed_window_keeps_finished_episodes_only(monkeypatch, capsys):
    def close_in_second(episode, t):
        return [pygame.event.Event(pygame.QUIT)] if (episode, t) == (1, 3) else arrows(episode, t)

    argv = ["--env", "GridWorld-v0", "--dataset", "tt/q-v0", "--episodes", "3", "--max-steps", "5"]
    assert run_teleop(monkeypatch, [*argv, *FAST], close_in_second) == 0
    assert json.loads(capsys.readouterr().out)["ended"] == "quit"
    assert minari.load_dataset("tt/q-v0").total_episodes == 1

    def close_in_first(episode, t):
        return [pygame.event.Event(pygame.QUIT)] if t == 2 else []

    argv[3] = "tt/none-v0"
    assert run_teleop(monkeypatch, [*argv, *FAST], close_in_first) == 1
    assert "nothing written" in capsys.readouterr().err
    assert "tt/none-v0" not in minari.list_local_datasets()


def test_ctrl_c_keeps_finished_episodes(monkeypatch, capsys):
    def interrupt(episode, t):
        return [KeyboardInterrupt()] if (episode, t) == (1, 2) else arrows(episode, t)

    argv = ["--env", "GridWorld-v0", "--dataset", "tt/c-v0", "--episodes", "2", "--max-steps", "4"]
    assert run_teleop(monkeypatch, [*argv, *FAST], interrupt) == 130
    assert minari.load_dataset("tt/c-v0").total_episodes == 1


def test_restart_pause_and_slow_motion(monkeypatch, capsys):
    def controls_(episode, t):
        if t == 2 and not hasattr(controls_, "restarted"):
            controls_.restarted = True
            return [key(pygame.K_r)]
        return [key(pygame.K_p), key(pygame.K_p), key(pygame.K_s)] if t == 1 else []

    argv = ["--env", "GridWorld-v0", "--dataset", "tt/r-v0", "--max-steps", "4", *FAST]
    assert run_teleop(monkeypatch, argv, controls_) == 0
    data = minari.load_dataset("tt/r-v0")
    assert data.total_episodes == 1 and data[0].actions.tolist() == [4, 4, 4, 4]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--env", "DAG-v0"], "DAG-v0 has no teleop mapping"),
        (["--env", "GridWorld-v0", "--episodes", "0"], "--episodes"),
        (["--env", "GridWorld-v0", "--dataset", "bad id"], "dataset id"),
    ],
)
def test_bad_input_is_a_clear_error(argv, message, capsys):
    if "--dataset" not in argv:
        argv = [*argv, "--dataset", "tt/x-v0"]
    assert main(["teleop", *argv]) == 2
    assert message in capsys.readouterr().err


def test_missing_pygame_names_the_extra(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "pygame", None)
    assert main(["teleop", "--env", "GridWorld-v0", "--dataset", "tt/x-v0"]) == 2
    assert 'pip install "fluids-bench[human]"' in capsys.readouterr().err


def test_simulated_human_without_a_window(capsys):
    argv = ["teleop", "--env", "GridWorld-v0", "--dataset", "tt/sim-v0", "--episodes", "2"]
    assert main([*argv, "--simulated-human", "delay=1,epsilon=0"]) == 0
    ep = minari.load_dataset("tt/sim-v0")[0]
    labels = ep.infos["supervisor_action"][1:]
    assert ep.actions[1:].tolist() == labels[:-1].tolist()  # one step late
    assert set(ep.infos["provenance"][1:]) == {"simulated_human"}
    assert not math.isnan(ep.infos["reaction_time"][1])


def test_a_real_sigint_keeps_finished_episodes(monkeypatch, capsys):
    import os
    import signal

    def sigint(episode, t):
        if (episode, t) == (1, 2):
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C in the terminal
        return arrows(episode, t)

    # a process started in the background by a shell ignores SIGINT (and Python then installs
    # no handler): give this one Python's, as a terminal's foreground process has
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)

    argv = ["--env", "GridWorld-v0", "--dataset", "tt/s-v0", "--episodes", "2", "--max-steps", "4"]
    try:
        assert run_teleop(monkeypatch, [*argv, *FAST], sigint) == 130
    finally:
        signal.signal(signal.SIGINT, previous)
    assert minari.load_dataset("tt/s-v0").total_episodes == 1
