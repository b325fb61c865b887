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
Preisach hysteresis (temperature -> austenite fraction) for the rich SMA simulator.

Deliberately NOT a Prandtl-Ishlinskii operator: a continuous Preisach model whose relay
density is a smooth 2-D Gaussian in (centre, width) coordinates, evaluated exactly through
its Everett function and a stack of dominant input extrema (wiping-out + return-point memory).

Relay (alpha, beta): switches to austenite (1) when the input rises above alpha [degC] and
back to martensite (0) when it falls below beta.  Centre c = (alpha + beta)/2 ~ N(c0, sc^2),
width w = alpha - beta ~ N(w0, sw^2), independent, so alpha and beta are correlated.
With c0 = 60, w0 = 26, sc = sw/2 = 1.5 K the major loop has (1 % / 99 % points)
As = 68, Af = 78, Ms = 52, Mf = 42 degC.
"""
from numba import njit
import numpy as np

GRID_LO_C = 20.0    # Everett table lower edge [degC]; density is ~0 outside the grid
GRID_HI_C = 110.0   # upper edge [degC]
GRID_STEP_K = 0.1   # table resolution [K]
STACK_DEPTH = 512   # max stored extrema per wire (nested minor loops)


def everett_table(c0=60.0, w0=26.0, sc=1.5, sw=3.0):
    """
    Tabulate the normalised Everett function on a square grid.

    E(alpha, beta) = integral over {beta <= b <= a <= alpha} of mu(a, b) da db, with
    mu(a, b) = N((a + b)/2; c0, sc) * N(a - b; w0, sw) (Jacobian of (a, b) -> (c, w) is 1),
    normalised so that E(GRID_HI, GRID_LO) = 1.  Returns (table[i_alpha, j_beta], lo, step).
    """
    for name, val in (('c0', c0), ('w0', w0), ('sc', sc), ('sw', sw)):
        if not np.isfinite(val) or (name in ('sc', 'sw', 'w0') and val <= 0):
            raise ValueError(f'everett_table: bad {name}={val!r}')
    g = np.arange(GRID_LO_C, GRID_HI_C + 0.5 * GRID_STEP_K, GRID_STEP_K)
    a, b = np.meshgrid(g, g, indexing='ij')
    c, w = 0.5 * (a + b), a - b
    mu = np.exp(-0.5 * ((c - c0) / sc) ** 2 - 0.5 * ((w - w0) / sw) ** 2)
    mu[w < 0.0] = 0.0
    # sum over alpha' <= alpha (axis 0 ascending) and beta' >= beta (axis 1 descending)
    e = np.cumsum(np.cumsum(mu[:, ::-1], axis=1)[:, ::-1], axis=0)
    return e / e[-1, 0], GRID_LO_C, GRID_STEP_K


@njit(cache=True)
def everett(tab, lo, step, alpha, beta):
    """Bilinear interpolation of the Everett table, E = 0 for alpha <= beta."""
    if alpha <= beta:
        return 0.0
    n = tab.shape[0] - 1
    x = min(max((alpha - lo) / step, 0.0), n - 1e-9)
    y = min(max((beta - lo) / step, 0.0), n - 1e-9)
    i, j = int(x), int(y)
    fx, fy = x - i, y - j
    return ((1 - fx) * (1 - fy) * tab[i, j] + fx * (1 - fy) * tab[i + 1, j]
            + (1 - fx) * fy * tab[i, j + 1] + fx * fy * tab[i + 1, j + 1])


def new_state(n_wires, u0):
    """
    Preisach memory for n_wires starting fully martensitic at input u0 [degC].

    The history is 'came from -inf, rose to u0'.  Returns (stack, prefix, top, direction,
    u_prev) arrays; stack[w, 0] is the -inf sentinel (grid lower edge).
    """
    stack = np.full((n_wires, STACK_DEPTH), GRID_LO_C)
    prefix = np.zeros((n_wires, STACK_DEPTH))
    top = np.zeros(n_wires, dtype=np.int64)
    direction = np.ones(n_wires, dtype=np.int64)
    u_prev = np.full(n_wires, float(u0))
    return stack, prefix, top, direction, u_prev


@njit(cache=True)
def _push(stack, prefix, top, w, tab, lo, step, value):
    """Store a turning point; prefix[k] = sum of Everett terms of consecutive extrema."""
    k = top[w] + 1
    if k >= stack.shape[1]:     # pathological nesting: forget the oldest inner pair
        k -= 2
    stack[w, k] = value
    if k % 2 == 1:              # odd index = maximum: + E(max, previous min)
        prefix[w, k] = prefix[w, k - 1] + everett(tab, lo, step, value, stack[w, k - 1])
    else:                       # even index = minimum: - E(previous max, min)
        prefix[w, k] = prefix[w, k - 1] - everett(tab, lo, step, stack[w, k - 1], value)
    top[w] = k


@njit(cache=True)
def preisach_step(state, w, tab, lo, step, u):
    """
    Advance wire w's memory to input u [degC]; return austenite fraction in [0, 1].

    a = sum_k (+E(M_k, m_{k-1}) - E(M_k, m_k)) + last segment, over the alternating dominant
    extrema (m_0 = -inf); extrema exceeded by the input are wiped out.
    """
    stack, prefix, top, direction, u_prev = state
    up = u_prev[w]
    if u > up:
        if direction[w] < 0:
            _push(stack, prefix, top, w, tab, lo, step, up)
            direction[w] = 1
        while top[w] >= 2 and u >= stack[w, top[w] - 1]:
            top[w] -= 2
    elif u < up:
        if direction[w] > 0:
            _push(stack, prefix, top, w, tab, lo, step, up)
            direction[w] = -1
        while top[w] >= 3 and u <= stack[w, top[w] - 1]:
            top[w] -= 2
    u_prev[w] = u
    k = top[w]
    if direction[w] > 0:
        a = prefix[w, k] + everett(tab, lo, step, u, stack[w, k])
    else:
        a = prefix[w, k] - everett(tab, lo, step, stack[w, k], u)
    return min(max(a, 0.0), 1.0)
