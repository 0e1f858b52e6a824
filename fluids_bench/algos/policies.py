"""The scikit-learn learner families (kept here for existing imports; they live in
`fluids_bench.algos.learners.sklearn`, next to the learner protocol and the torch learners)."""

from fluids_bench.algos.learners.protocol import Policy, check_action_space, features
from fluids_bench.algos.learners.sklearn import (
    FAMILIES,
    MODELS,
    PREDICTION_CACHE_SIZE,
    FittedPolicy,
    KernelRidgeClassifier,
    PolicySpec,
    SklearnLearner,
    SpanLinearSVC,
    distinct_rows,
    fit_policy,
)

__all__ = [
    "FAMILIES",
    "MODELS",
    "PREDICTION_CACHE_SIZE",
    "FittedPolicy",
    "KernelRidgeClassifier",
    "Policy",
    "PolicySpec",
    "SklearnLearner",
    "SpanLinearSVC",
    "check_action_space",
    "distinct_rows",
    "features",
    "fit_policy",
]
