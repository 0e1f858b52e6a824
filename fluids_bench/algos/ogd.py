"""Online gradient on-policy imitation (ch. 2, "Policy Gradient"; ch. 4, Theorem 2).

Instead of refitting on the aggregate (DAgger's Follow-The-Leader), take a gradient step on the
loss of the latest on-policy data only (Online Gradient Descent, Cheng et al. 2018):

    theta^{k+1} = theta^k - eta grad_theta E_{p(xi | theta^k)} J(theta, theta* | xi) |_{theta^k}

(the source writes the step with `+` for a reward; on a loss it descends). The policy class
is linear in standardised features, so the gradient is exact:

- Box actions: `pi_theta(x) = W^T phi(x)`, squared L2 loss, gradient `2/n Phi^T (Phi W - U)`;
- Discrete actions: linear softmax scores, cross-entropy (a convex surrogate of the 0/1
  loss), gradient `1/n Phi^T (softmax(Phi W) - Y)`; the policy takes the arg-max.

`phi(x) = ((x - m) / s, 1)` with `m, s` from the initial demonstrations, fixed afterwards.
The learner acts alone (beta = 0) after the initial supervisor demonstrations.

With a user's learner in `config.policy` (not a `PolicySpec`, which OGD ignores: its class is
the linear one above) the step is the learner's own: `partial_fit(observations, labels)` when it
has one, else `fit`, on the initial demonstrations and then on each iteration's on-policy pairs
only. A warm-started learner (the torch ones) then takes its gradient steps on the latest loss
from the weights it had, which is OGD with the learner's optimiser; a learner that refits from
scratch becomes "follow the latest loss".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from fluids_bench.algos.actors import SUPERVISOR, LearnerActor
from fluids_bench.algos.config import RunConfig
from fluids_bench.algos.harness import Harness, ProgressCallback
from fluids_bench.algos.learners.protocol import LearnerPolicy, features
from fluids_bench.algos.results import RunResult
from fluids_bench.core.validation import check_float, check_int


@dataclass(frozen=True, kw_only=True)
class OGDConfig(RunConfig):
    """`learning_rate` is eta; `steps_per_iteration` gradient steps on each iteration's loss."""

    learning_rate: float = 0.5
    steps_per_iteration: int = 1
    initial_demos: int = 1

    def __post_init__(self) -> None:
        super().__post_init__()
        where = type(self).__name__
        check_float(where, "learning_rate", self.learning_rate, 0.0, lo_open=True)
        check_int(where, "steps_per_iteration", self.steps_per_iteration, 1)
        check_int(where, "initial_demos", self.initial_demos, 1)


class LinearPolicy:
    """`pi(x) = argmax / identity of phi(x) W`; immutable (a step returns a new policy)."""

    def __init__(
        self,
        action_space: spaces.Space[Any],
        mean: np.ndarray,
        scale: np.ndarray,
        weights: np.ndarray,
    ) -> None:
        self.action_space = action_space
        self.discrete = isinstance(action_space, spaces.Discrete)
        self.mean, self.scale, self.weights = mean, scale, weights

    @classmethod
    def zeros(cls, action_space: spaces.Space[Any], observations: np.ndarray) -> LinearPolicy:
        X = features(observations)
        scale = X.std(axis=0)
        scale[scale == 0.0] = 1.0
        outputs = (
            action_space.n
            if isinstance(action_space, spaces.Discrete)
            else int(np.prod(action_space.shape))
        )
        return cls(action_space, X.mean(axis=0), scale, np.zeros((X.shape[1] + 1, outputs)))

    def phi(self, observations: np.ndarray) -> np.ndarray:
        X = (features(observations) - self.mean) / self.scale
        return np.hstack([X, np.ones((len(X), 1))])

    def predict(self, observations: np.ndarray) -> np.ndarray:
        scores = self.phi(observations) @ self.weights
        if self.discrete:
            return (np.argmax(scores, axis=1) + self.action_space.start).astype(np.int64)
        actions = scores.reshape((len(scores), *self.action_space.shape))
        return np.clip(actions, self.action_space.low, self.action_space.high)

    def act(self, observation: np.ndarray) -> Any:
        return self.predict(np.asarray(observation)[None])[0]

    def gradient(self, observations: np.ndarray, labels: np.ndarray) -> np.ndarray:
        """Gradient of the mean per-pair loss at the current weights."""
        Phi = self.phi(observations)
        scores = Phi @ self.weights
        if self.discrete:
            scores = scores - scores.max(axis=1, keepdims=True)
            probabilities = np.exp(scores)
            probabilities /= probabilities.sum(axis=1, keepdims=True)
            codes = np.asarray(labels).reshape(-1).astype(np.int64) - self.action_space.start
            probabilities[np.arange(len(codes)), codes] -= 1.0
            return Phi.T @ probabilities / len(Phi)
        targets = np.asarray(labels, dtype=np.float64).reshape(len(Phi), -1)
        return 2.0 * Phi.T @ (scores - targets) / len(Phi)

    def step(
        self, observations: np.ndarray, labels: np.ndarray, learning_rate: float
    ) -> LinearPolicy:
        weights = self.weights - learning_rate * self.gradient(observations, labels)
        return LinearPolicy(self.action_space, self.mean, self.scale, weights)


def descend(
    policy: LinearPolicy, observations: np.ndarray, labels: np.ndarray, config: OGDConfig
) -> LinearPolicy:
    for _ in range(config.steps_per_iteration):
        policy = policy.step(observations, labels, config.learning_rate)
    return policy


def learner_step(harness: Harness, observations: np.ndarray, labels: np.ndarray) -> LearnerPolicy:
    """One OGD step of the run's own learner on the latest pairs only."""
    learner = harness.learner
    assert learner is not None
    step = getattr(learner, "partial_fit", None)
    with harness.training():
        (step if callable(step) else learner.fit)(observations, labels)
    return LearnerPolicy(learner, harness.action_space)


def run(config: OGDConfig, progress: ProgressCallback | None = None) -> RunResult:
    with Harness("ogd", config, progress) as harness:
        if harness.learner is not None:
            return run_learner(harness)
        demos = harness.collect_many(SUPERVISOR, config.initial_demos)
        pairs = [harness.aggregate(demo) for demo in demos]
        observations = np.concatenate([p[0] for p in pairs])
        labels = np.concatenate([p[1] for p in pairs])
        with harness.training():
            policy = descend(
                LinearPolicy.zeros(harness.action_space, observations), observations, labels, config
            )
        harness.set_policy(policy)
        harness.record(0, demos)

        for iteration in range(1, config.iterations + 1):
            rollouts = harness.collect_many(LearnerActor(policy), config.demos_per_iteration)
            pairs = [harness.aggregate(trajectory) for trajectory in rollouts]
            # f_k is the loss on this iteration's on-policy data only
            observations = np.concatenate([p[0] for p in pairs])
            labels = np.concatenate([p[1] for p in pairs])
            with harness.training():
                policy = descend(policy, observations, labels, config)
            harness.set_policy(policy)
            harness.record(iteration, rollouts)
        return harness.result()


def run_learner(harness: Harness) -> RunResult:
    """OGD's loop with the run's own learner (see the module's docstring)."""
    config = harness.config
    assert isinstance(config, OGDConfig)
    demos = harness.collect_many(SUPERVISOR, config.initial_demos)
    pairs = [harness.aggregate(demo) for demo in demos]
    policy = learner_step(
        harness, np.concatenate([p[0] for p in pairs]), np.concatenate([p[1] for p in pairs])
    )
    harness.set_policy(policy)
    harness.record(0, demos)
    for iteration in range(1, config.iterations + 1):
        rollouts = harness.collect_many(LearnerActor(policy), config.demos_per_iteration)
        pairs = [harness.aggregate(trajectory) for trajectory in rollouts]
        policy = learner_step(
            harness, np.concatenate([p[0] for p in pairs]), np.concatenate([p[1] for p in pairs])
        )
        harness.set_policy(policy)
        harness.record(iteration, rollouts)
    return harness.result()
