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
Compiled hot loops of the hysteresis operators (numba, cached on disk).

All play-type operators of the package (the classical Prandtl-Ishlinskii backlash of
eq. (5) and the backlash with saturation of eq. (6)) reduce to one normalised element
acting on the input u:

    s_i(k) = clip( clip( s_i(k-1), u(k) - r_i, u(k) + r_i ), lo_i, hi_i )      (K1)

r_i is the half-width of the play (input units), [lo_i, hi_i] its saturation band
(lo = -inf, hi = +inf for the classical operator). The operator output is

    y(k) = y0 + k1 * u(k) + sum_i w_i * s_i(k)                                   (K2)

See `hysteresis.ModifiedPrandtlIshlinskii` for the mapping from the paper's
(M, K, K1, h) parameters to (r, lo, hi, w, k1).
"""
from typing import Tuple

from numba import njit
import numpy as np


def kernel_array(x: np.ndarray) -> np.ndarray:
    """
    Return `x` as a C-contiguous, writable float64 array (a copy only if it is not one).

    numba compiles a kernel once per array type it is called with, and a strided view (a
    CSV column, a decimated record) or a read-only one (a broadcast ambient, a bag's buffer)
    is another type: every input array that reaches a kernel from outside the package's own
    allocations passes through here, so each kernel compiles once.
    """
    return np.require(x, dtype=np.float64, requirements=('C', 'W'))


@njit(cache=True, fastmath=False)
def play_features(u: np.ndarray, r: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                  s0: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Return the states s_i(k) of every element, eq. (K1), as an (n, N) array, and the last."""
    n = u.shape[0]
    m = r.shape[0]
    out = np.empty((n, m))
    s = s0.copy()
    for k in range(n):
        uk = u[k]
        for i in range(m):
            v = s[i]
            a = uk - r[i]
            b = uk + r[i]
            if v < a:
                v = a
            elif v > b:
                v = b
            if v < lo[i]:
                v = lo[i]
            elif v > hi[i]:
                v = hi[i]
            s[i] = v
            out[k, i] = v
    return out, s


@njit(cache=True, fastmath=True)
def play_output(u: np.ndarray, r: np.ndarray, lo: np.ndarray, hi: np.ndarray, w: np.ndarray,
                k1: float, y0: float, s0: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return the operator output y(k), eq. (K2), without storing the element states, and s_last.

    This is the benchmarked kernel (operator updates per second). The inner loop is
    branch-free min/max so LLVM can vectorise it across elements.
    """
    n = u.shape[0]
    m = r.shape[0]
    y = np.empty(n)
    s = s0.copy()
    for k in range(n):
        uk = u[k]
        acc = 0.0
        for i in range(m):
            v = min(max(s[i], uk - r[i]), uk + r[i])
            v = min(max(v, lo[i]), hi[i])
            s[i] = v
            acc += w[i] * v
        y[k] = y0 + k1 * uk + acc
    return y, s


@njit(cache=True)
def _branch_value(u: float, s: np.ndarray, r: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                  w: np.ndarray, k1: float, y0: float, up: bool) -> float:
    """Return the output reached by moving the input monotonically from the state s to u."""
    acc = y0 + k1 * u
    for i in range(r.shape[0]):
        if up:
            v = max(s[i], u - r[i])
        else:
            v = min(s[i], u + r[i])
        v = min(max(v, lo[i]), hi[i])
        acc += w[i] * v
    return acc


@njit(cache=True)
def play_inverse(y_target: np.ndarray, r: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 w: np.ndarray, k1: float, y0: float, s0: np.ndarray, u0: float, u_min: float,
                 u_max: float) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return the right inverse of eq. (K2): inputs u(k) with H[u](k) = y_target(k), last state.

    From the current state, the output reached by a monotone input move is a
    non-decreasing piecewise-linear function of the end point (every element is a
    clipped play), so each sample is solved exactly on the branch it lies on: the
    breakpoints of that branch are where an element starts or stops moving
    (u = s_i +/- r_i, lo_i +/- r_i, hi_i +/- r_i). Targets beyond the reachable range are
    clipped to [u_min, u_max]; on flat stretches (all elements saturated, k1 = 0) the
    input nearest to the previous one is returned.
    """
    n = y_target.shape[0]
    m = r.shape[0]
    u_out = np.empty(n)
    s = s0.copy()
    u_prev = u0
    bp = np.empty(6 * m + 2)
    for k in range(n):
        yt = y_target[k]
        y_here = _branch_value(u_prev, s, r, lo, hi, w, k1, y0, True)
        up = yt >= y_here
        # candidate breakpoints on the chosen side of u_prev, sorted along the motion
        nb = 0
        for i in range(m):
            for c in (s[i] + r[i], s[i] - r[i], lo[i] + r[i], lo[i] - r[i],
                      hi[i] + r[i], hi[i] - r[i]):
                if np.isfinite(c) and ((up and c > u_prev and c < u_max)
                                       or ((not up) and c < u_prev and c > u_min)):
                    bp[nb] = c
                    nb += 1
        bp[nb] = u_max if up else u_min
        nb += 1
        seg = np.sort(bp[:nb])
        if not up:
            seg = seg[::-1]
        ua = u_prev
        ya = y_here
        u_sol = seg[nb - 1]
        for j in range(nb):
            ub = seg[j]
            yb = _branch_value(ub, s, r, lo, hi, w, k1, y0, up)
            if (up and yb >= yt) or ((not up) and yb <= yt):
                if yb != ya:
                    u_sol = ua + (yt - ya) * (ub - ua) / (yb - ya)
                else:
                    u_sol = ua
                break
            ua = ub
            ya = yb
        # advance the state along the branch to the solution
        for i in range(m):
            if up:
                v = max(s[i], u_sol - r[i])
            else:
                v = min(s[i], u_sol + r[i])
            s[i] = min(max(v, lo[i]), hi[i])
        u_out[k] = u_sol
        u_prev = u_sol
    return u_out, s


@njit(cache=True)
def relay_states(u: np.ndarray, alpha: np.ndarray, beta: np.ndarray,
                 x0: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Return Preisach relay states (n, N) int8, eq. (4): +1 above alpha, -1 below beta."""
    n = u.shape[0]
    m = alpha.shape[0]
    out = np.empty((n, m), dtype=np.int8)
    x = x0.copy()
    for k in range(n):
        uk = u[k]
        for i in range(m):
            if uk > alpha[i]:
                x[i] = 1
            elif uk < beta[i]:
                x[i] = -1
            out[k, i] = x[i]
    return out, x


@njit(cache=True)
def column_range(a: np.ndarray, b: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return (lowest, highest) value of each column over the rows of both (n, m) arrays.

    One pass: the regression needs each element's visited state range at every solve.
    """
    m = a.shape[1]
    lo = np.full(m, np.inf)
    hi = np.full(m, -np.inf)
    for x in (a, b):
        for k in range(x.shape[0]):
            for i in range(m):
                v = x[k, i]
                if v < lo[i]:
                    lo[i] = v
                if v > hi[i]:
                    hi[i] = v
    return lo, hi


@njit(cache=True)
def delayed_rows(x: np.ndarray, at: np.ndarray, delay_samples: float) -> np.ndarray:
    """
    Return every column of x (n, m) delayed by `delay_samples`, at the sample indices `at`.

    Row k is (1 − a) x[i0] + a x[i0 + 1] with f = max(at_k − delay_samples, 0), i0 = ⌊f⌋,
    a = f − i0 (the linear interpolation of `core.actuator.delay_signal`, holding the first
    sample before the record starts). One pass: the regression needs only these rows of a
    full-rate matrix, at every solve of a delayed model.
    """
    n, m = x.shape
    out = np.empty((at.shape[0], m))
    for k in range(at.shape[0]):
        f = max(at[k] - delay_samples, 0.0)
        i0 = int(np.floor(f))
        a = f - i0
        i1 = min(i0 + 1, n - 1)
        for i in range(m):
            out[k, i] = (1.0 - a) * x[i0, i] + a * x[i1, i]
    return out
