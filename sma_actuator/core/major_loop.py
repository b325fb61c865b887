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
Major-loop hysteresis models of the wire: temperature u [°C] -> length y (y0 cold, 0 hot).

Two laws for the martensite fraction xi on the major-loop branches:

* cosine law of the paper, eqs. (1)-(2) (Drahos [5]):
      heating  xi = 0.5 [cos K_A (u - As) + 1]   for As < u < Af,  K_A = pi / (Af - As)
      cooling  xi = 0.5 [cos K_M (u - Mf) + 1]   for Mf < u < Ms,  K_M = pi / (Ms - Mf)
* Ikuta's exponential (sigmoid) law [4]:
      heating  xi = 1 / (1 + exp(k_A (u - (As + Af)/2))),  k_A = 2 ln(19) / (Af - As)
      cooling  xi = 1 / (1 + exp(k_M (u - (Ms + Mf)/2))),  k_M = 2 ln(19) / (Ms - Mf)
  (so xi passes 95 % and 5 % at the start and finish temperatures).

Output y = y0 * xi. The paper notes these laws describe only the major loop; to run them
in continuous control without jumps, a reversal at (u_r, xi_r) scales the new branch
through the reversal point (Liang-Rogers / Ikuta minor-loop rule):
      heating  xi = xi_r * f_h(u) / f_h(u_r)
      cooling  1 - xi = (1 - xi_r) * (1 - f_c(u)) / (1 - f_c(u_r))
which is continuous, monotone on each branch and reduces to eqs. (1)-(2) from a full state.
"""
from __future__ import annotations

from typing import Optional

from numba import njit
import numpy as np
from numpy.typing import ArrayLike

from .validate import finite_array, finite_scalar

COSINE, IKUTA = 0, 1
_LN19 = np.log(19.0)


@njit(cache=True)
def _branch(kind: int, heating: bool, u: float, a_s: float, a_f: float, m_s: float,
            m_f: float) -> float:
    """Return the major-loop martensite fraction f_h(u) (heating) or f_c(u) (cooling)."""
    lo, hi = (a_s, a_f) if heating else (m_f, m_s)
    if kind == COSINE:
        if u <= lo:
            return 1.0
        if u >= hi:
            return 0.0
        return 0.5 * (np.cos(np.pi / (hi - lo) * (u - lo)) + 1.0)
    k = 2.0 * _LN19 / (hi - lo)
    x = k * (u - 0.5 * (lo + hi))
    if x > 700.0:
        return 0.0
    return 1.0 / (1.0 + np.exp(x))


@njit(cache=True)
def _simulate(kind: int, u: np.ndarray, a_s: float, a_f: float, m_s: float, m_f: float,
              state: np.ndarray) -> np.ndarray:
    """
    Return the martensite fraction for each sample.

    state = [u_prev, xi_prev, direction, u_r, xi_r] is updated in place.
    """
    n = u.shape[0]
    xi_out = np.empty(n)
    u_prev, xi, direction, u_r, xi_r = state[0], state[1], state[2], state[3], state[4]
    for k in range(n):
        uk = u[k]
        if uk != u_prev:
            d = 1.0 if uk > u_prev else -1.0
            if d != direction:   # reversal: remember where this branch starts
                u_r, xi_r, direction = u_prev, xi, d
            if d > 0:
                f_r = _branch(kind, True, u_r, a_s, a_f, m_s, m_f)
                f = _branch(kind, True, uk, a_s, a_f, m_s, m_f)
                new = xi_r * f / f_r if f_r > 1e-12 else 0.0
                xi = min(xi, new)
            else:
                f_r = _branch(kind, False, u_r, a_s, a_f, m_s, m_f)
                f = _branch(kind, False, uk, a_s, a_f, m_s, m_f)
                new = 1.0 - (1.0 - xi_r) * (1.0 - f) / (1.0 - f_r) if f_r < 1.0 - 1e-12 else 1.0
                xi = max(xi, new)
            u_prev = uk
        xi_out[k] = xi
    state[0], state[1], state[2], state[3], state[4] = u_prev, xi, direction, u_r, xi_r
    return xi_out


class MajorLoopHysteresis:
    """
    Major-loop model y = y0 * xi(u) with cosine (kind='cosine') or Ikuta (kind='ikuta') branches.

    Parameters: As, Af, Ms, Mf [°C] with As < Af and Mf < Ms; y0 output when cold (length
    or strain units of your choice). Streaming `step(u)`, batch `simulate(u)`, `reset()`.
    The reset state is cold and fully martensitic (xi = 1), as the wire is after cooling.
    """

    def __init__(self, As: float = 68.0, Af: float = 78.0, Ms: float = 52.0, Mf: float = 42.0,
                 y0: float = 1.0, kind: str = 'cosine'):
        self.As, self.Af = finite_scalar('As', As), finite_scalar('Af', Af)
        self.Ms, self.Mf = finite_scalar('Ms', Ms), finite_scalar('Mf', Mf)
        self.y0 = finite_scalar('y0', y0)
        if self.As >= self.Af:
            raise ValueError(
                f'As must be below Af (austenite start < finish), got As={As}, Af={Af}')
        if self.Mf >= self.Ms:
            raise ValueError(
                f'Mf must be below Ms (martensite finish < start), got Mf={Mf}, Ms={Ms}')
        if kind not in ('cosine', 'ikuta'):
            raise ValueError(f"kind must be 'cosine' or 'ikuta', got {kind!r}")
        self.kind = kind
        self._kind = COSINE if kind == 'cosine' else IKUTA
        self.reset()

    def reset(self, u0: Optional[float] = None) -> None:
        """Go to the cold, fully martensitic state (xi = 1) at u0 [°C] (default Mf - 10 °C)."""
        u0 = self.Mf - 10.0 if u0 is None else finite_scalar('u0', u0)
        self._state = np.array([u0, 1.0, -1.0, u0, 1.0])

    @property
    def martensite_fraction(self) -> float:
        """Return the current martensite fraction xi in [0, 1]."""
        return float(self._state[1])

    def step(self, u: float) -> float:
        """Advance by one sample of temperature u [°C]; return the length y."""
        x = _simulate(self._kind, np.array([finite_scalar('u', u)]), self.As, self.Af,
                      self.Ms, self.Mf, self._state)
        return self.y0 * float(x[0])

    def simulate(self, u: ArrayLike, reset: bool = True) -> np.ndarray:
        """Return the lengths for temperatures u [°C] (from the reset state unless reset=False)."""
        u = finite_array('u', u)
        if reset:
            self.reset(min(u[0], self.Mf - 10.0))
        return self.y0 * _simulate(self._kind, u, self.As, self.Af, self.Ms, self.Mf, self._state)
