"""Who acts during a rollout: the sampling distribution `p(u | x, psi)` of ch. 1.

An actor maps `(observation, supervisor label, rng)` to the executed action. The label is the
supervisor's action for the current state (the env's `info["supervisor_action"]`), so every
actor can be written without knowing the env:

- `SUPERVISOR`: `delta(pi*(x))`, behaviour cloning's sampling;
- `LearnerActor`: `delta(pi_theta(x))`, on-policy sampling;
- `NoisySupervisorActor`: `pi*(x) + eps` with `eps ~ N(0, Sigma)` for Box actions,
  or a different action with probability `epsilon` for Discrete ones (noise injection, DART);
- `MixtureActor`: the supervisor with probability `beta` and the learner otherwise,
  drawn every step (DAgger's `pi_i = beta_i pi* + (1 - beta_i) pi_hat_i`).

Actors draw only from the `rng` they are given, never from a global generator.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from gymnasium import spaces

from fluids_bench.algos.policies import Policy, check_action_space


class Actor(Protocol):
    def __call__(self, observation: np.ndarray, label: Any, rng: np.random.Generator) -> Any:
        """The action to execute in the state with `observation` and supervisor `label`."""
        ...


def SUPERVISOR(observation: np.ndarray, label: Any, rng: np.random.Generator) -> Any:  # noqa: N802
    """The supervisor acts: the executed action is its label."""
    return label


class LearnerActor:
    """The learner's policy acts."""

    def __init__(self, policy: Policy) -> None:
        self.policy = policy

    def __call__(self, observation: np.ndarray, label: Any, rng: np.random.Generator) -> Any:
        return self.policy.act(observation)


class NoisySupervisorActor:
    """The supervisor's label with injected noise.

    Box actions: `label + L z` with `z ~ N(0, I)` and `L L^T = covariance`, clipped to the
    action bounds. Discrete actions: with probability `epsilon` one of the other actions,
    uniformly, so that `epsilon` is exactly the chance of executing a non-supervisor action
    (the disagreement probability DART estimates).
    """

    def __init__(
        self,
        action_space: spaces.Space[Any],
        *,
        covariance: np.ndarray | None = None,
        epsilon: float | None = None,
    ) -> None:
        self.action_space = action_space
        self.discrete = check_action_space(action_space)
        if self.discrete:
            if epsilon is None or not 0.0 <= epsilon <= 1.0:
                raise ValueError(
                    f"NoisySupervisorActor: epsilon is {epsilon!r}; allowed: [0, 1] for Discrete"
                )
            self.epsilon = float(epsilon)
        else:
            dim = int(np.prod(action_space.shape))
            cov = np.asarray(covariance, dtype=np.float64)
            if covariance is None or cov.shape != (dim, dim) or not np.allclose(cov, cov.T):
                raise ValueError(
                    f"NoisySupervisorActor: covariance must be a symmetric {dim}x{dim} matrix "
                    f"for {action_space}"
                )
            eigenvalues, eigenvectors = np.linalg.eigh(cov)
            if eigenvalues.min() < -1e-9 * max(1.0, abs(eigenvalues).max()):
                raise ValueError("NoisySupervisorActor: covariance is not positive semi-definite")
            self.factor = eigenvectors * np.sqrt(np.clip(eigenvalues, 0.0, None))

    def __call__(self, observation: np.ndarray, label: Any, rng: np.random.Generator) -> Any:
        if self.discrete:
            # draw both numbers every step so the stream does not depend on the outcome
            flip, shift = rng.random(), int(rng.integers(1, self.action_space.n))
            if flip < self.epsilon:
                start = self.action_space.start
                return np.int64(start + (int(label) - start + shift) % self.action_space.n)
            return label
        z = rng.standard_normal(self.factor.shape[1])
        noisy = np.asarray(label, dtype=np.float64).reshape(-1) + self.factor @ z
        noisy = noisy.reshape(self.action_space.shape).astype(self.action_space.dtype)
        return np.clip(noisy, self.action_space.low, self.action_space.high)


class MixtureActor:
    """The supervisor with probability `beta`, otherwise `other` (a learner), every step."""

    def __init__(self, beta: float, other: Actor) -> None:
        if not 0.0 <= beta <= 1.0:
            raise ValueError(f"MixtureActor: beta is {beta!r}; allowed: [0, 1]")
        self.beta = beta
        self.other = other

    def __call__(self, observation: np.ndarray, label: Any, rng: np.random.Generator) -> Any:
        if rng.random() < self.beta:
            return label
        return self.other(observation, label, rng)


def stateless(actor: Actor) -> bool:
    """Whether `actor` is one of this module's actors (its action a function of the
    observation, the label and the generator alone), so that episodes may share it step by
    step (`fluids_bench.algos.vector_rollout`)."""
    if actor is SUPERVISOR or isinstance(actor, LearnerActor | NoisySupervisorActor):
        return True
    return isinstance(actor, MixtureActor) and stateless(actor.other)
