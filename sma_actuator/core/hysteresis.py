# Copyright 2026 sma_actuator developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Operator hysteresis models of the paper, section 2: Preisach relays and Prandtl-Ishlinskii.

* `PreisachModel`: y = y0 + sum_i mu_i gamma_{alpha_i beta_i}[u], relays of eq. (4), the
  discrete form of eq. (3). `PreisachModel.grid(21)` is the paper's Fig. 5 set of 231 relays.
* `PlayHysteresis`: superposition of (saturated) play operators in the normalised form of
  `kernels` (K1)-(K2). Its two named forms are
  - `PrandtlIshlinskii(h, K)`: classical PI of backlash operators, eq. (5);
  - `ModifiedPrandtlIshlinskii.from_paper(M, K, K1, h)`: backlash with saturation, eq. (6).
* `PlayHysteresis.inverse()` gives the exact inverse operator H^-1 (used for compensation).

Mapping of eq. (6) to the normalised element: with z = y - K1 u the element is
z = clip(clip(z, (K-K1)u - Kh, (K-K1)u + Kh), -M, M); dividing by a = K - K1 gives
s = clip(clip(s, u - r, u + r), -M/a, M/a) with r = K h / a, so
w = a, r = K h / (K - K1), lo/hi = -/+ M / (K - K1) (shifted by an optional centre c),
and the K1 u terms of all elements add to one linear term k1 = sum K1.
The saturation thresholds u_m = (K h + M)/(K - K1) of the paper are then hi + r.
"""
from __future__ import annotations

from typing import Any, Dict, Optional, Tuple

import numpy as np
from numpy.typing import ArrayLike

from . import kernels
from .validate import finite_array, finite_scalar, non_negative_array, same_length


class PlayHysteresis:
    """
    y = y0 + k1 u + sum_i w_i s_i with saturated plays s_i (kernels eq. K1-K2).

    r: play half-widths [input units] (>= 0); lo, hi: saturation bands (use -inf/+inf for
    none); w: weights [output/input units]; k1: linear slope; y0: offset.
    Streaming `step(u)` keeps state; `simulate(u)` runs a batch from the reset state.
    The reset state (`initial_state`) is the lower branch for saturated elements (an SMA
    wire cold and fully martensitic) and the virgin state for unsaturated ones.
    """

    def __init__(self, r: ArrayLike, lo: ArrayLike, hi: ArrayLike, w: ArrayLike,
                 k1: float = 0.0, y0: float = 0.0):
        self.r = kernels.kernel_array(non_negative_array('r (play half-widths)', r))
        self.lo = kernels.kernel_array(lo)
        self.hi = kernels.kernel_array(hi)
        self.w = kernels.kernel_array(finite_array('w (weights)', w, min_len=0))
        same_length(r=self.r, lo=self.lo, hi=self.hi, w=self.w)
        if np.isnan(self.lo).any() or np.isnan(self.hi).any():
            raise ValueError('lo/hi (saturation bands) contain NaN')
        if (self.lo > self.hi).any():
            raise ValueError('lo (lower saturation) must not exceed hi (upper saturation)')
        self.k1 = finite_scalar('k1', k1)
        self.y0 = finite_scalar('y0', y0)
        self._s = None
        self._u_last = None

    @property
    def n_operators(self) -> int:
        """Return the number of play operators."""
        return self.r.shape[0]

    def initial_state(self, u0: float) -> np.ndarray:
        """
        Return the reset element states s_i at input u0.

        Saturated elements start on the lower branch, s = clip(u0 - r, lo, hi) (cold, fully
        martensitic wire). Unsaturated (classical, eq. 5) elements start from the virgin
        state z = 0 of Prandtl-Ishlinskii theory, s = clip(0, u0 - r, u0 + r).
        """
        u0 = finite_scalar('u0', u0)
        lower = np.clip(u0 - self.r, self.lo, self.hi)
        virgin = np.clip(0.0, u0 - self.r, u0 + self.r)
        return np.where(np.isfinite(self.lo) | np.isfinite(self.hi), lower, virgin)

    def reset(self, u0: float = 0.0) -> None:
        """Reset the streaming state to the lower branch at input u0."""
        self._s = self.initial_state(u0)
        self._u_last = float(u0)

    @property
    def state(self) -> Optional[np.ndarray]:
        """Return a copy of the element states s_i (None before reset)."""
        return None if self._s is None else self._s.copy()

    def step(self, u: float) -> float:
        """Advance one sample with input u; return the output (eq. K2)."""
        u = finite_scalar('u', u)
        if self._s is None:
            self.reset(u)
        s = np.minimum(np.maximum(self._s, u - self.r), u + self.r)
        self._s = np.minimum(np.maximum(s, self.lo), self.hi)
        self._u_last = u
        return self.y0 + self.k1 * u + float(self.w @ self._s)

    def features(self, u: ArrayLike, s0: Optional[ArrayLike] = None) -> np.ndarray:
        """Return the element states over a batch, shape (n, N): least-squares regressors."""
        u = kernels.kernel_array(finite_array('u', u))
        s0 = (self.initial_state(u[0]) if s0 is None
              else kernels.kernel_array(finite_array('s0', s0)))
        out, _ = kernels.play_features(u, self.r, self.lo, self.hi, s0)
        return out

    def simulate(self, u: ArrayLike, s0: Optional[ArrayLike] = None) -> np.ndarray:
        """Return the output for an input sequence, from the reset state at u[0] (or s0)."""
        u = kernels.kernel_array(finite_array('u', u))
        s0 = (self.initial_state(u[0]) if s0 is None
              else kernels.kernel_array(finite_array('s0', s0)))
        y, _ = kernels.play_output(u, self.r, self.lo, self.hi, self.w, self.k1, self.y0, s0)
        return y

    def output_range(self) -> Tuple[float, float]:
        """Return (y_min, y_max) reachable for inputs within the (finite) saturation bands."""
        lo = np.where(np.isfinite(self.lo), self.lo, 0.0)
        hi = np.where(np.isfinite(self.hi), self.hi, 0.0)
        u_lo = float(np.min(lo - self.r)) if self.n_operators else 0.0
        u_hi = float(np.max(hi + self.r)) if self.n_operators else 0.0
        return (self.y0 + self.k1 * u_lo + float(self.w @ lo),
                self.y0 + self.k1 * u_hi + float(self.w @ hi))

    def inverse(self, u_min: float = -1e9,
                u_max: float = 1e9) -> InversePlayHysteresis:
        """Return the inverse operator H^-1: output targets -> inputs (`InversePlayHysteresis`)."""
        return InversePlayHysteresis(self, u_min, u_max)

    def to_dict(self) -> Dict[str, Any]:
        """Return the parameters as plain data (for YAML model files)."""
        return {'r': self.r.tolist(), 'lo': self.lo.tolist(), 'hi': self.hi.tolist(),
                'w': self.w.tolist(), 'k1': self.k1, 'y0': self.y0}

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> PlayHysteresis:
        """Build the operator from `to_dict` data (its inverse)."""
        return cls(d['r'], d['lo'], d['hi'], d['w'], d.get('k1', 0.0), d.get('y0', 0.0))


class PrandtlIshlinskii(PlayHysteresis):
    """
    Classical Prandtl-Ishlinskii operator, eq. (5): y = y0 + sum_i K_i * backlash_{h_i}[u].

    h: backlash half-widths (the paper's h) [input units]; K: slopes (the paper's K),
    non-negative for a well-posed, invertible operator.
    """

    def __init__(self, h: ArrayLike, K: ArrayLike, y0: float = 0.0):
        K = non_negative_array('K (backlash slopes)', K)
        h = non_negative_array('h (backlash half-widths)', h)
        n = len(h)
        super().__init__(h, np.full(n, -np.inf), np.full(n, np.inf), K, 0.0, y0)


class ModifiedPrandtlIshlinskii(PlayHysteresis):
    """
    Modified PI of backlash-with-saturation elements, eq. (6) (the paper's Fig. 10-11).

    Construct from the paper's per-element parameters with `from_paper(M, K, K1, h, c)`,
    or directly in normalised form (r, lo, hi, w, k1, y0) as `PlayHysteresis`.
    """

    @classmethod
    def from_paper(cls, M: ArrayLike, K: ArrayLike, K1: ArrayLike, h: ArrayLike,
                   c: ArrayLike = 0.0, y0: float = 0.0) -> ModifiedPrandtlIshlinskii:
        """
        Build the operator from the elements of eq. (6).

        Each element has saturation M, backlash slope K, saturated slope K1 < K and
        half-width h, centred at input c (the paper uses c = 0).
        """
        M = non_negative_array('M (saturation levels)', M)
        K = finite_array('K (backlash slopes)', K)
        K1 = finite_array('K1 (saturated slopes)', K1)
        h = non_negative_array('h (backlash half-widths)', h)
        c = np.broadcast_to(np.asarray(c, dtype=float), M.shape)
        same_length(M=M, K=K, K1=K1, h=h)
        a = K - K1
        if (a <= 0).any():
            raise ValueError(
                'K (backlash slope) must exceed K1 (saturated slope) in every element')
        r = K * h / a
        lo, hi = c - M / a, c + M / a
        # element output K1 (u - c) + a (s - c): collect the constant and linear parts
        y0 = finite_scalar('y0', y0) - float(np.sum(K1 * c + a * c))
        return cls(r, lo, hi, a, float(np.sum(K1)), y0)


def backlash_saturation_reference(u: np.ndarray, M: float, K: float, K1: float,
                                  h: float) -> np.ndarray:
    """
    Step one element of eq. (6) literally as printed in the paper (pure Python).

    It is an executable transcription of eq. (6) to check the compiled kernel against.
    Starts on the lower saturation line at u[0].
    """
    u_m = (K * h + M) / (K - K1)
    y = np.empty(len(u))
    # lower (rising) branch at u[0], clipped to the saturation lines
    y_prev = K1 * u[0] + min(max((K - K1) * u[0] - K * h, -M), M)
    u_prev = u[0]
    for k, uk in enumerate(u):
        u_plus = (y_prev - K1 * u_prev + K * h) / (K - K1)
        u_minus = (y_prev - K1 * u_prev - K * h) / (K - K1)
        if uk > u_m:
            yk = K1 * uk + M
        elif uk < -u_m:
            yk = K1 * uk - M
        elif uk > u_plus:
            yk = K * (uk - h)
        elif uk < u_minus:
            yk = K * (uk + h)
        else:
            yk = y_prev + K1 * (uk - u_prev)
        y[k] = yk
        y_prev, u_prev = yk, uk
    return y


class InversePlayHysteresis:
    """
    Exact inverse of a `PlayHysteresis` with non-negative weights: y targets -> inputs u.

    Keeps the forward operator's state, so H[H^-1[y]] = y for every reachable target,
    across major and minor loops. Unreachable targets are clipped to the reachable range
    (inputs limited to [u_min, u_max]).
    """

    def __init__(self, forward: PlayHysteresis, u_min: float = -1e9, u_max: float = 1e9):
        if (forward.w < 0).any():
            raise ValueError('w (weights) must be non-negative for the operator to be invertible')
        if forward.k1 < 0:
            raise ValueError('k1 must be non-negative for the operator to be invertible')
        self.forward = forward
        self.u_min, self.u_max = finite_scalar('u_min', u_min), finite_scalar('u_max', u_max)
        self._s = None
        self._u = None

    def reset(self, u0: float = 0.0) -> None:
        """Reset to the forward operator's lower-branch state at input u0."""
        self._s = self.forward.initial_state(u0)
        self._u = float(u0)

    def step(self, y: float) -> float:
        """Return the input that drives the operator to output y from the current state."""
        if self._s is None:
            self.reset(self.u_min if np.isfinite(self.u_min) and self.u_min > -1e8 else 0.0)
        u, self._s = self._solve(np.array([finite_scalar('y', y)]), self._s, self._u,
                                 self.u_min, self.u_max)
        self._u = float(u[0])
        return self._u

    def solve(self, y: float, state: np.ndarray, u: float, u_min: Optional[float] = None,
              u_max: Optional[float] = None) -> float:
        """
        Return the input that drives the operator from `state` to output y, keeping no state.

        state: element states s_i, u: the input they were reached with (a forward
        operator's `state` and last input); u_min, u_max: the input limits of this solve
        (default: the inverse's own).
        """
        lo = self.u_min if u_min is None else u_min
        hi = self.u_max if u_max is None else u_max
        u_out, _ = self._solve(np.array([finite_scalar('y', y)]), state, u, lo, hi)
        return float(u_out[0])

    def simulate(self, y: ArrayLike, u0: float = 0.0) -> np.ndarray:
        """Return the input for a target sequence y, from the lower-branch state at u0."""
        y = finite_array('y', y)
        self.reset(u0)
        u, self._s = self._solve(y, self._s, self._u, self.u_min, self.u_max)
        self._u = float(u[-1])
        return u

    def _solve(self, y: np.ndarray, s: np.ndarray, u: float, u_min: float,
               u_max: float) -> Tuple[np.ndarray, np.ndarray]:
        """Return `kernels.play_inverse` of targets y from state (s, u): (inputs, last state)."""
        f = self.forward
        return kernels.play_inverse(y, f.r, f.lo, f.hi, f.w, f.k1, f.y0, s, u, u_min, u_max)


class PreisachModel:
    """
    Preisach operator, eqs. (3)-(4): y = y0 + sum_i mu_i gamma_i[u], relays alpha_i >= beta_i.

    gamma switches to +1 for u > alpha, to -1 for u < beta, otherwise keeps its value.
    The reset state is all relays at -1 (input from far below).
    """

    def __init__(self, alpha: ArrayLike, beta: ArrayLike, mu: ArrayLike, y0: float = 0.0):
        self.alpha = finite_array('alpha (relay up thresholds)', alpha)
        self.beta = finite_array('beta (relay down thresholds)', beta)
        self.mu = finite_array('mu (relay weights)', mu)
        same_length(alpha=self.alpha, beta=self.beta, mu=self.mu)
        if (self.alpha < self.beta).any():
            raise ValueError('alpha must be >= beta for every relay (switch-up above switch-down)')
        self.y0 = finite_scalar('y0', y0)
        self.reset()

    @classmethod
    def grid(cls, n_levels: int = 21, lo: float = -1.0, hi: float = 1.0,
             mu: ArrayLike = 1.0, y0: float = 0.0) -> PreisachModel:
        """Build relays on an even grid alpha >= beta in [lo, hi]: n(n+1)/2 (21 -> 231, Fig. 5)."""
        if int(n_levels) < 1:
            raise ValueError(f'n_levels must be >= 1, got {n_levels}')
        levels = np.linspace(lo, hi, int(n_levels))
        a, b = np.meshgrid(levels, levels, indexing='ij')
        keep = a >= b
        alpha, beta = a[keep], b[keep]
        return cls(alpha, beta, np.broadcast_to(np.asarray(mu, float), alpha.shape).copy(), y0)

    def reset(self) -> None:
        """Set all relays down (-1)."""
        self._x = -np.ones(len(self.alpha), dtype=np.int8)

    def features(self, u: ArrayLike) -> np.ndarray:
        """Return the relay states over a batch, (n, N) int8, from the reset state."""
        self.reset()
        out, self._x = kernels.relay_states(finite_array('u', u), self.alpha, self.beta, self._x)
        return out

    def simulate(self, u: ArrayLike) -> np.ndarray:
        """Return the output for an input sequence from the reset state."""
        return self.y0 + self.features(u) @ self.mu

    def step(self, u: float) -> float:
        """Advance one sample; return the output."""
        out, self._x = kernels.relay_states(np.array([finite_scalar('u', u)]), self.alpha,
                                            self.beta, self._x)
        return self.y0 + float(out[0] @ self.mu)
