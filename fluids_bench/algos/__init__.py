"""Imitation-learning algorithms: one readable module each.

- `bc` Behavior Cloning; `noise` isotropic
  noise injection; `dart` DART (off-policy);
- `dagger` DAgger and DAgger-B; `shiv` SHIV
  with the ch. 6 query-selection baselines (`query`);
  `ogd` online-gradient on-policy learning (on-policy);
- shared pieces: `rollout` (the one rollout function),
  `actors`, `dataset`,
  `learners` (the fit/predict learner protocol, the scikit-learn
  families, also importable as `policies`, and the torch learners),
  `harness`,
  `evaluation`, `results`;
  `registry` names them all.

Every algorithm runs on any env that implements `fluids_bench.core.supervisor` (in the
env or in a wrapper, e.g. `SupervisorWrapper`) with a Box
observation space and a Discrete or Box action space.
"""
