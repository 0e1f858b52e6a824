"""People in the loop: teleoperation, retroactive relabelling and human-noise DART.

* :mod:`~fluids_bench.human.controls`: per-task control schemes, pure functions from input
  state (keys held, mouse, joystick) to an action (tested without a window);
* :mod:`~fluids_bench.human.recording`: the datasets a person records (Minari, written
  atomically, with the env states stored next to them so any step can be shown again);
* :mod:`~fluids_bench.human.window`: the pygame window (the ``human`` extra) of
  ``fluids-bench teleop`` and ``fluids-bench relabel``;
* :mod:`~fluids_bench.human.simulated`: simulated people (a delayed, noisy copy of the
  supervisor) that stand in for a person in tests and examples;
* :mod:`~fluids_bench.human.offline`: fitting learners on recorded datasets, and DAgger with
  retroactive labels (collect, relabel offline, aggregate, retrain).
"""
