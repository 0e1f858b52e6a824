"""WorldBatch, FaultBatch and SupervisorBatch: B worlds, their fault trackers and their
supervisors stored as rows step, record and propose exactly as each alone (invariants, as dm_control's: same state, same collisions, same
proposals and PID memory; rows that are masked out stay untouched)."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

from fluids_bench.tasks.fluids.sim.batch import PER_TRACKER, PER_WORLD, FaultBatch, WorldBatch
from fluids_bench.tasks.fluids.sim.config import SceneConfig
from fluids_bench.tasks.fluids.sim.fault import FaultTracker
from fluids_bench.tasks.fluids.supervisor.batch import SupervisorBatch
from fluids_bench.tasks.fluids.supervisor.episode import make_world
from fluids_bench.tasks.fluids.supervisor.stack import DrivingSupervisor, SupervisorConfig

SCENE = SceneConfig(layout="four_way", num_cars=8, num_pedestrians=4)
NO_RECOVERY = SupervisorConfig(recovery=False)  # jolted cars drive on (OMPL is not the point)


def _worlds(seeds):
    return [make_world(SCENE, seed) for seed in seeds]


def _same(a, b) -> None:
    for name in PER_WORLD:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(a.light_state, b.light_state)
    assert (a.time, a.steps, a.log) == (b.time, b.steps, b.log)


def test_batches_step_and_propose_as_alone_and_leave_masked_worlds_alone():
    seeds = [3, 4, 5, 6]
    batched, alone = _worlds(seeds), _worlds(seeds)
    batch = WorldBatch(batched)
    sups = [DrivingSupervisor(w, NO_RECOVERY) for w in batched]
    sups_alone = [DrivingSupervisor(w, NO_RECOVERY) for w in alone]
    sup_batch = SupervisorBatch(sups)
    trackers, trackers_alone = [FaultTracker(w) for w in batched], [FaultTracker(w) for w in alone]
    fault_batch = FaultBatch(trackers)
    for sup, world in zip(sups + sups_alone, batched + alone, strict=True):
        sup.prepare(world)
    rng = np.random.default_rng(0)
    collisions = 0
    for step in range(150):
        stepping = rng.random(len(seeds)) < 0.8
        if step % 30 == 7:  # push agents into each other: collisions and off-road cars
            for a, b in zip(batched, alone, strict=True):
                jolt = rng.normal(0.0, [2.0, 2.0, 0.6], (a.n, 3))
                a.state[:, :3] += jolt
                b.state[:, :3] += jolt
        for i in np.flatnonzero(stepping):
            batch.controls[i] = sups[i].commit()
        events = batch.step(stepping)
        fault_batch.update(stepping, batch)
        sup_batch.plan(stepping, batch, batch.lights)
        sup_batch.propose(stepping, batch)
        for i in range(len(seeds)):
            if stepping[i]:
                assert events[i] == sups_alone[i].execute(alone[i])  # alone: step, prepare
                trackers_alone[i].update()
                sups_alone[i].prepare(alone[i])
                collisions += len(events[i])
            else:
                assert events[i] == []
            _same(batched[i], alone[i])
            for name in ("steer_prev", "steer_int", "speed_int"):
                assert (
                    getattr(sups[i].pid, name).tobytes()
                    == getattr(sups_alone[i].pid, name).tobytes()
                )
            assert sups[i].proposed.tobytes() == sups_alone[i].proposed.tobytes()
            assert sups[i].targets.tobytes() == sups_alone[i].targets.tobytes()
            assert trackers[i]._recorded == trackers_alone[i]._recorded
            kept = min(trackers[i]._recorded, len(trackers[i]._ring))
            for name in PER_TRACKER:
                a, b = getattr(trackers[i], name), getattr(trackers_alone[i], name)
                if name == "_ring":  # slots not yet written hold whatever np.empty gave
                    a, b = a[:kept], b[:kept]
                assert a.tobytes() == b.tobytes(), name
    assert collisions > 0  # the collision path ran


def test_bound_worlds_are_views_and_rebinding_copies_the_values_in():
    worlds = _worlds([1, 2])
    batch = WorldBatch(worlds)
    assert np.shares_memory(worlds[1].state, batch.rows["state"])
    fresh = copy.deepcopy(_worlds([9])[0])
    expected = fresh.state.copy()
    batch.bind(0, fresh)
    assert batch.worlds[0] is fresh and np.shares_memory(fresh.state, batch.rows["state"][0])
    np.testing.assert_array_equal(batch.rows["state"][0], expected)
    # the clock and the light lookup are entries of the batch's arrays too
    assert np.shares_memory(fresh._clock, batch.times[0:1])
    assert np.shares_memory(fresh._step_count, batch.steps[0:1])
    assert fresh.light_state is fresh.lights.current
    assert np.shares_memory(fresh.light_state, batch.lights[0])


def test_batched_clock_reads_the_ticks_a_world_counts_alone_and_a_clock_set_by_hand_ticks_alone():
    worlds = _worlds([1, 2, 3])
    batch = WorldBatch(worlds)
    alone = _worlds([1])[0]
    worlds[2].time = 0.05  # off the ticks: advanced by World.begin_step itself
    stepping = np.array([True, False, True])
    for _ in range(2000):
        batch._advance_clocks(stepping, worlds[0].dt)
        alone.begin_step()
    assert (worlds[0].time, worlds[0].steps) == (alone.time, alone.steps)
    assert (worlds[1].time, worlds[1].steps) == (0.0, 0)
    assert worlds[2].steps == 2000 and worlds[2].time == pytest.approx(200.05)


def test_batched_velocity_plan_equals_each_planner_and_zeroes_a_world_without_agents():
    worlds = _worlds([11, 12, 13])
    for world in worlds:  # a few steps in, so that the plans differ from the first one
        sup = DrivingSupervisor(world, NO_RECOVERY)
        for _ in range(7):
            sup.step(world)
    worlds[1].active[:] = False  # nothing to plan: its targets become 0
    batch = WorldBatch(worlds)
    sups = [DrivingSupervisor(w, NO_RECOVERY) for w in worlds]
    sup_batch = SupervisorBatch(sups)
    lights = np.stack([w.light_state for w in worlds])
    for sup in sups:
        sup.targets[:] = 7.0  # overwritten by the plan (world 2 is not due)
    sup_batch.plan_velocities(np.array([0, 1]), batch, lights)
    assert sups[0].targets.tobytes() == sups[0].planner.plan(worlds[0]).tobytes()
    assert sups[0].targets.any() and np.all(sups[1].targets == 0.0)
    assert np.all(sups[2].targets == 7.0)


def _as_pickled_before_rows(world, sup, tracker):
    """The objects' attributes as fluids-bench pickled them before their scalars became 0-d
    arrays (the clock, the light lookup, the fault record count, the proposal's memory)."""
    d = world.__dict__
    d["time"], d["steps"] = float(d.pop("_clock")), int(d.pop("_step_count"))
    lights = world.lights.__dict__
    lights["_last"] = lights.pop("current")  # the same array as world.light_state
    lights["_last"].setflags(write=False)
    lights["_valid"] = tuple(lights["_valid"].tolist())
    tracker.__dict__["_recorded"] = int(tracker.__dict__["_recorded"])
    sup.__dict__["_memory"] = tuple(np.array(row) for row in sup.__dict__["_memory"])


def test_objects_pickled_in_the_earlier_layout_load_and_continue_bit_for_bit():
    """Stored states (teleop datasets) written before this layout still restore."""
    world = make_world(SCENE, 5)
    sup, tracker = DrivingSupervisor(world, NO_RECOVERY), FaultTracker(world)
    for _ in range(12):
        sup.step(world)
        tracker.update()
    reference = pickle.loads(pickle.dumps((world, sup, tracker)))
    _as_pickled_before_rows(world, sup, tracker)
    loaded = pickle.loads(pickle.dumps((world, sup, tracker)))
    w0, s0, t0 = reference
    w1, s1, t1 = loaded
    assert w1.light_state is w1.lights.current
    for _ in range(60):
        for w, s, t in (reference, loaded):
            s.step(w)
            t.update()
        _same(w0, w1)
        assert s0.proposed.tobytes() == s1.proposed.tobytes()
        assert int(t0._recorded) == int(t1._recorded)
        assert t0.ran_red.tobytes() == t1.ran_red.tobytes()
