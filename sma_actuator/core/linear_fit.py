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
Least squares for the hysteresis weights: the inner, linear half of the identification.

Position is linear in the play-operator weights (eq. 5-6), so for each trial of the outer
search the weights follow by non-negative least squares, the paper's "least mean squares"
tuning with v_i >= 0 (an invertible operator). Both solvers work on the Cholesky-reduced
m x m system of the Gram matrix instead of the n x m regressors (n samples >> m weights).
"""
import numpy as np
from scipy.optimize import lsq_linear, nnls


# ridge on the (unit-norm scaled) hysteresis weights: elements the training data hardly
# excite would otherwise take arbitrary weights and spoil the held-out prediction
RIDGE = 1e-10


def nnls_with_offset(X: np.ndarray, y: np.ndarray, free_cols: int = 0) -> np.ndarray:
    """
    Min ‖X b − y‖ with b >= 0 except the last `free_cols` columns (sign-free, split ±).

    Solved on the Cholesky factor R of the (scaled) Gram matrix, ‖R b − R^-T X^T y‖ having
    the same minimiser as ‖X b − y‖, so the active-set NNLS works on an m x m system
    instead of n x m (n samples >> m regressors).
    """
    R, z, scale = _reduced(X, y, negated=free_cols)
    b, _ = nnls(R, z, maxiter=50 * R.shape[1])
    b = b / scale
    if free_cols:
        b = np.concatenate([b[:-2 * free_cols], b[-2 * free_cols:-free_cols] - b[-free_cols:]])
    return b


def _reduced(X: np.ndarray, y: np.ndarray, negated: int = 0) -> tuple:
    """
    (R, z, scale).

    Cholesky factor R of the column-scaled Gram matrix (plus the ridge; it also keeps ± column
    pairs apart) and z = R^-T Xs^T y, so that ‖R c − z‖ has the minimiser of ‖X b − y‖ with b = c /
    scale, on an m x m instead of an n x m system.

    negated: the last `negated` columns are also appended with the opposite sign, [X, −X_l]
    (a sign-free coefficient as the difference of two non-negative ones). Their Gram
    entries are those of X with the sign flipped, so the n x (m + l) matrix is never built.
    """
    G, Xty = X.T @ X, X.T @ y   # one pass each over the large X; A.T @ A is a BLAS syrk
    if negated:
        tail = slice(G.shape[0] - negated, None)
        G = np.block([[G, -G[:, tail]], [-G[tail, :], G[tail, tail]]])
        Xty = np.concatenate([Xty, -Xty[tail]])
    scale = np.sqrt(np.diag(G))   # a new array (np.diag of a 2-D array is a read-only view)
    scale[scale == 0] = 1.0
    G = G / np.outer(scale, scale)
    G[np.diag_indices_from(G)] += RIDGE * np.trace(G) / len(G)
    R = np.linalg.cholesky(G).T
    return R, np.linalg.solve(R.T, Xty / scale), scale


def box_ls(X: np.ndarray, y: np.ndarray, lower: np.ndarray,
           upper: np.ndarray) -> np.ndarray:
    """
    Solve min ‖X b − y‖ subject to lower <= b <= upper (scipy's bounded-variable LS).

    On the same Cholesky-reduced system as `nnls_with_offset`.
    """
    R, z, scale = _reduced(X, y)
    lo, hi = lower * scale, upper * scale
    # the bounds relaxed to signs: a minimiser inside the box is the box's minimiser, and
    # the active-set NNLS finds it far faster than BVLS, which then only runs when it is not
    free = np.flatnonzero((lo != 0.0) | np.isfinite(hi))
    c, _ = nnls(np.hstack([R, -R[:, free]]), z, maxiter=50 * (R.shape[1] + free.size))
    b = c[:R.shape[1]]
    b[free] -= c[R.shape[1]:]
    if not (np.all(b >= lo) and np.all(b <= hi)):
        b = lsq_linear(R, z, bounds=(lo, hi), method='bvls').x
    return b / scale
