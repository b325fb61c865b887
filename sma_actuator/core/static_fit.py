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
Fits to quasi-static input/output curves (no time axis).

* `fit_static`: weights of the play operators (eq. 5 classical, eq. 6 modified) by
  non-negative least squares on a grid of thresholds designed from the input range.
* `fit_preisach`: relay weights mu >= 0 of the Preisach model (eq. 3-4) by NNLS on the
  relay states.
"""
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .hysteresis import PlayHysteresis, PreisachModel
from .linear_fit import nnls_with_offset
from .play_grids import play_grid
from .scoring import scores
from .validate import finite_array, same_length


@dataclass
class StaticFit:
    """Result of `fit_static`: the fitted operator and its scores (train/validation)."""

    model: PlayHysteresis
    train: dict
    validation: dict
    prediction: list = field(default_factory=list)


def _curve_list(u: np.ndarray, y: np.ndarray, curve: Optional[np.ndarray]) -> list:
    """Return [(curve id, input, output), ...] in file order, after checking the arrays."""
    u = finite_array('input', u)
    y = finite_array('output', y)
    same_length(input=u, output=y)
    curve = np.zeros(len(u), int) if curve is None else np.asarray(curve).astype(int)
    same_length(input=u, curve=curve)
    ids = list(dict.fromkeys(curve.tolist()))
    return [(c, u[curve == c], y[curve == c]) for c in ids]


def fit_static(u: np.ndarray, y: np.ndarray, curve: Optional[np.ndarray] = None,
               kind: str = 'modified', validate_odd: bool = True, n_widths: int = 8,
               n_centres: int = 10, nonneg: bool = True) -> StaticFit:
    """
    Fit a (classical or modified) PI operator to quasi-static input/output curves.

    Each curve is simulated from the reset state (cold, lower branch at its first input),
    as measured first-order reversal curves are. With validate_odd, even-numbered curves
    train and odd ones validate (the workbench convention); otherwise all train.
    nonneg=True constrains the weights to be non-negative (an invertible operator);
    nonneg=False is plain least squares.
    """
    curves = _curve_list(u, y, curve)
    train = [c for c in curves if not validate_odd or c[0] % 2 == 0]
    val = [c for c in curves if validate_odd and c[0] % 2 == 1]
    if not train:
        raise ValueError('no training curves (need curve ids with even numbers)')
    u_all = np.concatenate([c[1] for c in curves])
    grid = play_grid(u_all.min(), u_all.max(), kind, n_widths, n_centres)
    X = np.vstack([np.column_stack([grid.features(cu, grid.initial_state(u_all.min())),
                                    cu, np.ones_like(cu)]) for _, cu, _ in train])
    yt = np.concatenate([cy for _, _, cy in train])
    b = nnls_with_offset(X, yt, free_cols=1) if nonneg else np.linalg.lstsq(X, yt, rcond=None)[0]
    model = PlayHysteresis(grid.r, grid.lo, grid.hi, b[:-2], b[-2], b[-1])
    pred = [(c, model.simulate(cu, model.initial_state(u_all.min()))) for c, cu, _ in curves]
    by_id = dict(pred)

    def score(cs: list) -> Optional[dict]:
        if not cs:
            return None
        return scores(np.concatenate([cy for _, _, cy in cs]),
                      np.concatenate([by_id[c] for c, _, _ in cs]))
    return StaticFit(model, score(train), score(val), pred)


def fit_preisach(u: np.ndarray, y: np.ndarray, n_levels: int = 21,
                 u_range: Optional[tuple] = None) -> PreisachModel:
    """Fit a Preisach model, relays on an even grid over the input range, by NNLS (mu >= 0)."""
    u = finite_array('input', u)
    y = finite_array('output', y)
    same_length(input=u, output=y)
    lo, hi = u_range if u_range is not None else (u.min(), u.max())
    model = PreisachModel.grid(n_levels, lo, hi)
    X = np.column_stack([model.features(u).astype(float), np.ones_like(u)])
    b = nnls_with_offset(X, y, free_cols=1)
    return PreisachModel(model.alpha, model.beta, b[:-1], b[-1])
