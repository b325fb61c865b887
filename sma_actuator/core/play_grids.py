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
Threshold grids of play operators (eq. 5-6) for the identification, and their shaping.

* `play_grid`: an even grid over an input range; `adaptive_grid`: a fine grid placed where a
  coarse fit carries its weight; `prune_unused`: the weighted elements and their neighbours.
* Beyond the trained states: `narrow_bands` (an element stops where the data stopped
  showing it), `close_major_loop` (every element cold at the rest temperature) and
  `tie_loop_width` (the cooling branch tied to the heating one with the datasheet's loop
  proportions, `flexinol_loop_ratio`, when the data only heats).
"""
from typing import Optional

import numpy as np

from . import actuator as act
from . import kernels
from .hysteresis import PlayHysteresis


def play_grid(u_min: float, u_max: float, kind: str = 'modified', n_widths: int = 6,
              n_centres: int = 8) -> PlayHysteresis:
    """
    Threshold grid of play operators covering inputs in [u_min, u_max].

    classical: widths r_j = j/(n−1) · span/2 (unsaturated, eq. 5); modified: every width
    combined with n_centres saturation bands of half-width span/(2 n_centres) whose
    centres tile the span shifted by the width (eq. 6 elements centred across the range).
    Weights start at zero.
    """
    span = float(u_max - u_min)
    if not np.isfinite(span) or span <= 0:
        raise ValueError(f'input range must be finite and positive, got [{u_min}, {u_max}]')
    if kind == 'classical':
        r = np.linspace(0.0, 0.5 * span, n_widths + 4)
        inf = np.full(r.size, np.inf)
        return PlayHysteresis(r, -inf, inf, np.zeros(r.size))
    if kind != 'modified':
        raise ValueError(f"kind must be 'classical' or 'modified', got {kind!r}")
    widths = np.linspace(0.0, 0.4 * span, n_widths)
    band = 0.5 * span / n_centres
    rows = []
    for r in widths:
        # the element rises over [c - band + r, c + band + r]: tile that over the range
        centres = np.linspace(u_min + band - r, u_max - band - r, n_centres)
        rows += [(r, c - band, c + band) for c in centres]
    r, lo, hi = np.array(rows).T
    return PlayHysteresis(r, lo, hi, np.zeros(r.size))


def narrow_bands(params: act.ActuatorParams, duty_a: np.ndarray, duty_b: np.ndarray,
                 ambient: np.ndarray, dt: float) -> act.ActuatorParams:
    """
    Return `params` with each element's saturation band [lo, hi] narrowed to its states.

    The states are those it takes (either wire) when `params` is simulated on these
    (training) inputs.

    The simulation on these inputs is unchanged (every state visited lies in the narrowed
    band, so the clip never acts there), but beyond them an element stops where the data
    stopped showing it: a weight fitted to a small part of an element's band is not
    extrapolated over the rest, and the model saturates outside the trained range instead.
    Classical (unsaturated) elements are returned as they are.
    """
    h, n = params.hysteresis, len(duty_a)
    if not (np.isfinite(h.lo).all() and np.isfinite(h.hi).all()) or n == 0:
        return params
    fa, fb = np.empty((n, h.n_operators)), np.empty((n, h.n_operators))
    act.simulate_wires(act.kernel_inputs(duty_a, duty_b, ambient, np.zeros(n)), dt,
                       params.kernel_vector(),
                       act.kernel_hysteresis(h), act.initial_state(params),
                       (fa, fb, np.empty(n), np.empty(n), 0, 1))
    lo, hi = state_range(fa, fb)
    return params.with_changes(hysteresis=PlayHysteresis(h.r, lo, hi, h.w, h.k1, h.y0))


def state_range(fa: np.ndarray, fb: np.ndarray) -> tuple:
    """(lowest, highest) state of each element over the rows of either wire."""
    return kernels.column_range(fa, fb)


def _mass_points(x: np.ndarray, mass: np.ndarray, cell: float, lo: float, hi: float,
                 n: int) -> np.ndarray:
    """
    N sorted points in [lo, hi].

    a third spread evenly, the rest at quantiles of `mass` located at x, each mass smeared
    uniformly over ±cell/2 (a piecewise-linear CDF).

    The fine grid's resolution then follows where the coarse fit put its weight (where the
    wire transforms), while the even third keeps elements everywhere else in the range.
    """
    n_even = max(2, n // 3)
    even = np.linspace(lo, hi, n_even)
    ok = (mass > 0) & np.isfinite(x)
    if not ok.any() or n <= n_even:
        return np.linspace(lo, hi, n)
    knots = np.concatenate([x[ok] - 0.5 * cell, x[ok] + 0.5 * cell])
    order = np.argsort(knots)
    knots = np.clip(knots[order], lo, hi)
    steps = np.concatenate([mass[ok], -mass[ok]])[order] / cell    # density changes at knots
    density = np.cumsum(steps)[:-1]
    cdf = np.concatenate([[0.0], np.cumsum(np.maximum(density, 0.0) * np.diff(knots))])
    if cdf[-1] <= 0:
        return np.linspace(lo, hi, n)
    q = (np.arange(n - n_even) + 0.5) / (n - n_even)
    dense = np.interp(q * cdf[-1], cdf, knots)
    return np.sort(np.concatenate([even, dense]))


def adaptive_grid(h: PlayHysteresis, span: np.ndarray, u_lo: float, u_hi: float,
                  n_widths: int, n_centres: int) -> tuple:
    """
    Fine saturated-play grid refined where the coarse fit `h` carries its weight.

    Rising edges (centre + half-width) and half-widths are placed by `_mass_points` from
    each coarse element's share of the output in the training window, w · span (span: the
    range its state covers there, `_Problem.state_hi − state_lo`). Weighting by the whole
    band instead (w (hi − lo)) let a heavily weighted element the data hardly moves (one
    near the hottest state, fitting a few samples) pull the resolution away from where the
    wire transforms. Each element's band covers the cell between its edge and the
    neighbouring edges, so the edges tile [u_lo, u_hi] for every width.
    """
    mass = h.w * span
    if not np.isfinite(mass).all() or mass.sum() <= 0:
        return play_grid(u_lo, u_hi, 'modified', n_widths, n_centres), (n_widths, n_centres)
    edges = 0.5 * (h.lo + h.hi) + h.r
    cell = float(np.max(h.hi - h.lo))
    r_top = float(np.max(h.r[mass > 1e-3 * mass.sum()])) + cell
    e = _mass_points(edges, mass, cell, u_lo, u_hi, n_centres)
    e = e[np.concatenate([[True], np.diff(e) > 1e-3 * (u_hi - u_lo)])]
    widths = _mass_points(h.r, mass, max(np.diff(np.unique(h.r)).min(initial=cell), 1e-6),
                          0.0, r_top, n_widths)
    widths = np.unique(np.round(widths, 9))
    bounds = np.concatenate([[u_lo], 0.5 * (e[1:] + e[:-1]), [u_hi]])
    rows = [(r, b0 - r, b1 - r) for r in widths for b0, b1 in zip(bounds[:-1], bounds[1:])]
    r, lo, hi = np.array(rows).T
    return PlayHysteresis(r, lo, hi, np.zeros(r.size)), (len(widths), len(e))


def close_major_loop(grid: PlayHysteresis, u_rest: float) -> PlayHysteresis:
    """
    Return the saturated `grid` with every element fully cold at the rest temperature.

    An element of half-width r and band [lo, hi] falls back to lo on cooling only once
    its input is below lo − r; with lo < u_rest + r it would stay partly transformed at
    rest after any heating, and a model fitted on a record that never cooled fully would
    freeze above the measured rest. The material's major loop closes there (Mf above
    ambient), so lo is raised to u_rest + r (hi kept, an empty band is a constant):
    beyond the temperatures seen in training the model then saturates at the ends of the
    major loop instead of where the training stopped. Unsaturated (classical) elements
    are returned as they are.
    """
    if not (np.isfinite(grid.lo).all() and np.isfinite(grid.hi).all()):
        return grid
    lo = np.minimum(np.maximum(grid.lo, u_rest + grid.r), grid.hi)
    return PlayHysteresis(grid.r, lo, grid.hi, grid.w, grid.k1, grid.y0)


def flexinol_loop_ratio() -> float:
    """
    Return β = r / (c − θ_rest) of the datasheet loop (`core.actuator.flexinol_hysteresis`).

    r: the mean half-width of its elements, c − θ_rest: how far the loop's centre lies above
    the default ambient. For Flexinol LT (As 68, Af 78, Ms 52, Mf 42 °C at 22 °C) that is
    13 K / 38 K = 0.34: the cooling branch lies at (1 − β)/(1 + β) = 0.49 of the heating
    branch's height above ambient. The thermal model is linear in the excess temperature
    θ − θ_rest (eq. 7), so a heating gain G that is off by a factor scales both heights
    alike and β holds on the model's own temperature scale.
    """
    h, p = act.flexinol_hysteresis(), act.ActuatorParams()
    centre = 0.5 * (h.lo + h.hi)
    return float(np.mean(h.r) / (np.mean(centre) - p.ambient_c))


def tie_loop_width(grid: PlayHysteresis, u_rest: float, ratio: Optional[float],
                   edge: Optional[float] = None,
                   spread: Optional[tuple[float, float]] = None) -> PlayHysteresis:
    """
    Return the saturated `grid` with the elements' half-widths tied to the heating edge.

    An element of half-width r and band [lo, hi] rises over [lo + r, hi + r] on heating and
    falls over [lo − r, hi − r] on cooling. Data that only heats identifies the rising
    cells but not r: any width fits them, and the cooling is then predicted anywhere
    between the heating edge and the rest. With ratio β (`flexinol_loop_ratio`) the loop
    keeps the datasheet's proportions: one half-width r = f β (e − θ_rest) / (1 + β) for
    every element, e the heating edge (the loop centre c = e − r then lies
    (e − θ_rest)/(1 + β) above the rest and r = f β (c − θ_rest)), so the cooling branch
    spans as many kelvin as the heating branch, 2 r lower, as As-Af and Ms-Mf do. f spreads
    the widths of one cell over `spread` by their rank in the grid (the datasheet loop
    spreads them too, so minor loops keep a shape; default its min and max over mean
    half-width, 0.85 and 1.15). edge: the heating edge [°C] (the
    weight centre of a previous fit's rising cells, `heating_edge`); None: each element's
    own rising cell (before any fit). The rising cells are kept. ratio None, or
    unsaturated (classical) elements: `grid` is returned as it is.
    """
    if ratio is None or not (np.isfinite(grid.lo).all() and np.isfinite(grid.hi).all()):
        return grid
    if spread is None:
        datasheet = act.flexinol_hysteresis().r
        spread = (datasheet.min() / datasheet.mean(), datasheet.max() / datasheet.mean())
    cell = 0.5 * (grid.lo + grid.hi) + grid.r
    half = 0.5 * (grid.hi - grid.lo)
    widths = np.unique(grid.r)
    rank = np.searchsorted(widths, grid.r) / max(len(widths) - 1, 1)
    f = spread[0] + (spread[1] - spread[0]) * rank
    e = cell if edge is None else edge
    r = np.maximum(ratio * (e - u_rest) / (1.0 + ratio), 0.0) * f
    c = cell - r
    return PlayHysteresis(r, c - half, c + half, grid.w, grid.k1, grid.y0)


def heating_edge(h: PlayHysteresis, span: np.ndarray) -> Optional[float]:
    """
    Return the weight centre [°C] of the rising cells of hysteresis `h`.

    Σ m_i (c_i + r_i) / Σ m_i with m_i = w_i · span_i, the output each element gives over
    the state range `span` it covers in the training window (as `adaptive_grid` weighs).
    """
    mass = h.w * span
    if not np.isfinite(mass).all() or mass.sum() <= 0:
        return None
    return float(np.sum(mass * (0.5 * (h.lo + h.hi) + h.r)) / mass.sum())


def prune_unused(grid: PlayHysteresis, w: np.ndarray, shape: Optional[tuple],
                 centre_steps: int = 3) -> PlayHysteresis:
    """
    Elements with non-zero weight, dilated by one step in width and `centre_steps` in centre.

    Room for effects that shift where (in model temperature) the wire transforms.
    """
    used = w > 0
    if shape is not None:
        used = used.reshape(shape)
        grown = used.copy()
        grown[1:, :] |= used[:-1, :]
        grown[:-1, :] |= used[1:, :]
        for k in range(1, centre_steps + 1):
            grown[:, k:] |= used[:, :-k]
            grown[:, :-k] |= used[:, k:]
        used = grown.ravel()
    if not used.any():
        return grid
    return PlayHysteresis(grid.r[used], grid.lo[used], grid.hi[used], np.zeros(int(used.sum())))
