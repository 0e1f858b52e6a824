"""Imitation-learning algorithms: one readable module each.

- :mod:`~fluids_bench.algos.bc` Behavior Cloning; :mod:`~fluids_bench.algos.noise` isotropic
  noise injection; :mod:`~fluids_bench.algos.dart` DART (off-policy);
- :mod:`~fluids_bench.algos.dagger` DAgger and DAgger-B; :mod:`~fluids_bench.algos.shiv` SHIV
  with the ch. 6 query-selection baselines (:mod:`~fluids_bench.algos.query`);
  :mod:`~fluids_bench.algos.ogd` online-gradient on-policy learning (on-policy);
- shared pieces: :mod:`~fluids_bench.algos.rollout` (the one rollout function),
  :mod:`~fluids_bench.algos.actors`, :mod:`~fluids_bench.algos.dataset`,
  :mod:`~fluids_bench.algos.learners` (the fit/predict learner protocol, the scikit-learn
  families, also importable as :mod:`~fluids_bench.algos.policies`, and the torch learners),
  :mod:`~fluids_bench.algos.harness`,
  :mod:`~fluids_bench.algos.evaluation`, :mod:`~fluids_bench.algos.results`;
  :mod:`~fluids_bench.algos.registry` names them all.

Every algorithm runs on any env that implements :mod:`fluids_bench.core.supervisor` (in the
env or in a wrapper, e.g. :class:`~fluids_bench.core.supervisor.SupervisorWrapper`) with a Box
observation space and a Discrete or Box action space.
"""
