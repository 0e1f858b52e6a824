"""A small feed-forward policy evaluated in numpy, loaded from a hash-checked ``.npz`` file.

The locomotion supervisors that are trained policies ship as weight files inside the package.
No deep-learning framework is needed at run time: the forward pass is a few matrix products.

File format (``numpy.savez``): ``obs_mean`` and ``obs_std`` (the observation normaliser the
policy was trained with), then ``W0, b0, W1, b1, ...`` (layer ``i`` maps its input ``x`` to
``W_i @ x + b_i``; hidden layers use tanh). The output layer is squashed by tanh and scaled to the
action bounds, so the policy is never a linear function of the observation.
"""

from __future__ import annotations

import hashlib
import io
from pathlib import Path

import numpy as np


def sha256_of(path: str | Path) -> str:
    """Hex sha256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class MLPPolicy:
    """``a = low + (tanh(f(x)) + 1) / 2 * (high - low)``, ``f`` an MLP on the normalised observation."""

    def __init__(
        self,
        obs_mean: np.ndarray,
        obs_std: np.ndarray,
        weights: list[np.ndarray],
        biases: list[np.ndarray],
        action_low: np.ndarray,
        action_high: np.ndarray,
    ) -> None:
        if len(weights) != len(biases) or not weights:
            raise ValueError(
                f"MLPPolicy: {len(weights)} weight matrices and {len(biases)} bias vectors; "
                "allowed: equal, non-zero counts"
            )
        self.obs_mean = np.asarray(obs_mean, dtype=np.float64)
        self.obs_std = np.asarray(obs_std, dtype=np.float64)
        self.weights = [np.asarray(w, dtype=np.float64) for w in weights]
        self.biases = [np.asarray(b, dtype=np.float64) for b in biases]
        self.action_low = np.asarray(action_low, dtype=np.float64)
        self.action_high = np.asarray(action_high, dtype=np.float64)
        dim = self.obs_mean.shape[0]
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            if w.ndim != 2 or w.shape[1] != dim or b.shape != (w.shape[0],):
                raise ValueError(
                    f"MLPPolicy: layer {i} has W {w.shape}, b {b.shape} after an input of {dim}; "
                    "allowed: W (out, in) with in equal to the previous width, b (out,)"
                )
            dim = w.shape[0]
        # precomputed once: the label is computed every env step
        self._hidden = list(zip(self.weights[:-1], self.biases[:-1], strict=True))
        self._w_out, self._b_out = self.weights[-1], self.biases[-1]
        self._range = self.action_high - self.action_low
        if dim != self.action_low.shape[0]:
            raise ValueError(
                f"MLPPolicy: output width {dim}; allowed: the action dimension "
                f"{self.action_low.shape[0]}"
            )

    @property
    def obs_dim(self) -> int:
        return int(self.obs_mean.shape[0])

    def preactivation(self, obs: np.ndarray) -> np.ndarray:
        """The output layer's value before the tanh squashing (batched over leading axes)."""
        x = (obs - self.obs_mean) / self.obs_std
        for w, b in self._hidden:
            x = np.tanh(x @ w.T + b)
        return x @ self._w_out.T + self._b_out

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The deterministic action for ``obs`` (shape ``(obs_dim,)`` or ``(n, obs_dim)``)."""
        # the arithmetic (and so every bit of the result) is the training script's
        return self.action_low + (np.tanh(self.preactivation(obs)) + 1.0) * 0.5 * self._range

    def to_bytes(self) -> bytes:
        """The ``.npz`` bytes of this policy (the shipped file format)."""
        arrays = {"obs_mean": self.obs_mean, "obs_std": self.obs_std}
        arrays["action_low"] = self.action_low
        arrays["action_high"] = self.action_high
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            arrays[f"W{i}"] = w
            arrays[f"b{i}"] = b
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        return buf.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> MLPPolicy:
        with np.load(io.BytesIO(data)) as z:
            n = sum(1 for k in z.files if k.startswith("W"))
            return cls(
                z["obs_mean"],
                z["obs_std"],
                [z[f"W{i}"] for i in range(n)],
                [z[f"b{i}"] for i in range(n)],
                z["action_low"],
                z["action_high"],
            )

    @classmethod
    def load(cls, path: str | Path, sha256: str) -> MLPPolicy:
        """Load ``path`` after checking its bytes hash to ``sha256`` (a ValueError if not)."""
        data = Path(path).read_bytes()
        actual = hashlib.sha256(data).hexdigest()
        if actual != sha256:
            raise ValueError(
                f"MLPPolicy.load: weight file {str(path)!r} has sha256 {actual}; "
                f"allowed: the recorded {sha256}"
            )
        return cls.from_bytes(data)
