"""People in the loop: teleoperation, retroactive relabelling and human-noise DART.

* `controls`: per-task control schemes, pure functions from input
  state (keys held, mouse, joystick) to an action (tested without a window);
* `recording`: the datasets a person records (Minari, written
  atomically, with the env states stored next to them so any step can be shown again);
* `window`: the pygame window (the `human` extra) of
  `fluids-bench teleop` and `fluids-bench relabel`;
* `simulated`: simulated people (a delayed, noisy copy of the
  supervisor) that stand in for a person in tests and examples;
* `offline`: fitting learners on recorded datasets, and DAgger with
  retroactive labels (collect, relabel offline, aggregate, retrain).
"""
