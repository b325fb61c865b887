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
Identification of the thermal and hysteresis parameters (the paper's section 2.2-2.3 tuning).

Dynamic (`fit_dynamic`): (duty_a, duty_b, position[, ambient]) time series. Variable
projection: the outer nonlinear least squares (scipy.optimize.least_squares) adjusts the
thermal time constant and any free effect parameters; for each trial the wire temperatures
are simulated with the exact step (7d), the play-operator states of both wires are the
regressors, and the weights follow by NNLS (`linear_fit`; position is linear in them:
φ = φ0 + Σ_i v_i (s_i^a − s_b s_i^b) + k1 (θ_a − s_b θ_b)). Two stages: a coarse grid over
the whole temperature range finds the time constant and where the wire transforms, then a
fine grid over that active range gives the final weights (`play_grids`). Effects that feed
the output back into the regressors (phase resistance, stress coupling) use the previous
round's hysteresis in the feedback path, alternating until the weights settle; the sensor
polynomial is handled by regressing on p^-1(measured position). Train on the first
`train_fraction` of time; score the free-run simulation of the rest (`scoring`). The
dynamic fit runs as explicit stages (`prepare`, `input_range`, `fit_coarse`,
`refine_grid`, `prune_grid`, `fit_final`, `score_fit`), each taking the previous one's
frozen result. Quasi-static curves are fitted in `static_fit`.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Callable, Optional

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter

from . import actuator as act
from . import kernels
from .datakinds import (DynamicData, MIN_DUTY_EXCITATION, SAMPLING_TOLERANCE, Split,  # noqa: F401
                        TRAIN_FRACTION)
from .hysteresis import PlayHysteresis
from .linear_fit import box_ls, nnls_with_offset
from .play_grids import (adaptive_grid, close_major_loop, heating_edge, narrow_bands, play_grid,
                         prune_unused, state_range, tie_loop_width)
from .scoring import NEAR_NOISE, record_noise_rms, scores

# parameters that feed the hysteresis output back into its own regressors, and those
# solved linearly with the weights (no outer search): the roles declared in `ActuatorParams`
FEEDBACK_PARAMS = act.FEEDBACK_PARAMS
LINEAR_PARAMS = act.LINEAR_PARAMS
# the potentiometer polynomial's terms, expanded about the measured travel when fitted
SENSOR_TERMS = frozenset(act.EFFECT_PARAMETERS['sensor_nonlinearity'])
# feedback fixed-point iterations per settle (see `_settle`): enough for the feedback
# weights to reach their fixed point; more iterations do not change the fit
FIXED_POINT_STEPS = 4

# regression rows are thinned to about this rate: the thermal lag (~1 s) makes denser
# samples nearly redundant, and the Gram matrix cost scales with the row count
REGRESSION_RATE_HZ = 20.0
# stopping tolerance of the outer search (relative change of the squared error and of the
# parameters): 1e-4 of the cost is 5e-5 of the RMSE, far below any difference diagnose
# judges; scipy's 1e-8 spent a third of diagnose's time polishing converged fits
OUTER_TOL = 1e-4


# ------------------------------------------------------------------------- dynamic data
@dataclass
class DynamicFit:
    """Result of `fit_dynamic`: fitted parameters, scores and the free-run prediction."""

    params: act.ActuatorParams
    free: dict              # fitted values of the free nonlinear parameters
    train: dict
    validation: dict
    prediction: np.ndarray  # free-run position over the whole record [rad]
    trajectory: act.Trajectory
    n_train: int
    burn_in: int
    n_parameters: int
    grid: PlayHysteresis    # the threshold grid of the hysteresis (weights = fitted)

    @property
    def split(self) -> Split:
        """Return the train/validation split the fit was scored on."""
        return Split(self.n_train, self.burn_in)


_FIELDS = {f.name for f in fields(act.ActuatorParams)} | {'tau_s'}


def set_values(params: act.ActuatorParams, values: dict) -> act.ActuatorParams:
    """
    Return ActuatorParams with fitted values; 'tau_s' maps to the heat capacity (hA, G fixed).

    Names that are not ActuatorParams fields (plug-in parameters) are ignored here.
    """
    changes = {k: v for k, v in values.items() if k in _FIELDS}
    if 'tau_s' in changes:
        changes['heat_capacity_j_per_k'] = changes.pop('tau_s') * params.conductance_w_per_k
    return params.with_changes(**changes)


class _Problem:
    """
    One variable-projection problem on a threshold grid: data, split, grid, free layout.

    Immutable after construction: everything a call depends on beyond the problem (the
    nonlinear `values` plug-in hooks read, the hysteresis `ref` in the feedback path) is an
    argument, and every result (the linear solution with the state range it was regressed
    on) is returned.
    """

    def __init__(self, setup: 'Setup', grid: PlayHysteresis) -> None:
        """Build the problem of `setup` on the threshold `grid`."""
        data = setup.data
        self.setup, self.grid = setup, grid
        self.data, self.base = data, setup.base
        self.names = list(setup.free)
        self.n_train, self.burn_in = setup.n_train, setup.burn_in
        self.stride = max(1, int(round(1.0 / (data.dt * REGRESSION_RATE_HZ))))
        # the saturated (modified) operator stays bounded outside the trained temperature
        # range; a linear k1 (θ_a − θ_b) term would extrapolate without limit
        self.linear_term = not (np.isfinite(grid.lo).all() and np.isfinite(grid.hi).all())
        self.amb = (data.ambient if data.ambient is not None
                    else np.full(len(data), setup.base.ambient_c))
        self.keep = None if data.scored is None else np.asarray(data.scored, bool)
        self.direction = setup.direction

    def regressors(self, params: act.ActuatorParams, n: int, rows: slice = slice(None),
                   values: Optional[dict] = None,
                   ref: Optional[PlayHysteresis] = None) -> tuple:
        """
        Return (X, state_lo, state_hi): the linear-part columns over the first n samples.

        X is taken at `rows` of them: [s^a − s_b s^b, u_a − s_b u_b, (g_a, g_b), 1] (element
        states scaled by each wire's fatigue stroke loss; g_j its fatigue drift).
        state_lo/state_hi: the range each element's state covers at these rows (either
        wire). values: nonlinear values the input hook reads (default none); ref: the
        hysteresis in the feedback path (default: the grid with zero weights).
        """
        d, g = self.data, self.grid
        ref = g if ref is None else ref
        m = g.n_operators
        # the kernel records the (large) element arrays at the regression rows only; a
        # delay interpolates in time, so it needs them whole
        at = range(n)[slice(None) if params.delay_s > 0 else rows]
        fa, fb = np.empty((len(at), m)), np.empty((len(at), m))
        ua, ub = np.empty(len(at)), np.empty(len(at))
        st = act.initial_state(params.with_changes(hysteresis=ref))
        da, db, amb = self.inputs(values or {})
        inputs = act.kernel_inputs(da[:n], db[:n], amb[:n], np.zeros(n))
        ya, yb, _, _ = act.simulate_wires(inputs, d.dt, params.kernel_vector(),
                                          (g.r, g.lo, g.hi, ref.w, ref.k1, ref.y0), st,
                                          (fa, fb, ua, ub, at.start, max(at.step, 1)))
        sb = params.stroke_ratio_b
        drift = any(k in self.names for k in LINEAR_PARAMS)
        if self.fatigued(params):
            # each wire's shakedown over its own cycles in the reference (previous round)
            # model; the stroke loss scales the contraction from cold, so element states
            # count from their coldest trained state (then y_j = w (s_j − lo) / stroke exactly)
            g_a = act.fatigue_progress(params, act.transformation_cycles(ya))
            g_b = act.fatigue_progress(params, act.transformation_cycles(yb))
        # the range each element's state covers in the training window (either wire, at
        # these rows): the contraction fraction is normalised over it (see `with_linear`)
        state_lo, state_hi = state_range(fa, fb)
        if self.fatigued(params):
            g_a, g_b = g_a[at.start:at.stop:at.step], g_b[at.start:at.stop:at.step]
            keep_a, keep_b = 1.0 - params.fatigue_stroke * g_a, 1.0 - params.fatigue_stroke * g_b
            cold = np.where(np.isfinite(g.lo), state_lo, 0.0)
            fa = (fa - cold) * keep_a[:, None]
            fb = (fb - cold) * keep_b[:, None]
            ua, ub = ua * keep_a, ub * keep_b
        # X = [fa − s_b fb, u_a − s_b u_b (or 0), (g_a, g_b), 1], built in place
        n_drift = 2 if drift else 0
        X = np.empty((len(ua), m + 2 + n_drift))
        if sb != 1.0:   # a pass over the large array saved on the common equal strokes
            np.multiply(fb, sb, out=fb)
        np.subtract(fa, fb, out=X[:, :m])
        X[:, m] = (ua - sb * ub) if self.linear_term else 0.0
        if drift:
            X[:, m + 1], X[:, m + 2] = g_a, g_b
        X[:, -1] = 1.0
        if params.delay_s > 0:
            # act.delay_signal of every column, evaluated at the regression rows only
            X = kernels.delayed_rows(X, np.arange(*rows.indices(n)), params.delay_s / d.dt)
        return X, state_lo, state_hi

    def free_run_error(self, params: act.ActuatorParams, values: dict,
                       step: int = 1) -> np.ndarray:
        """
        Return the free-run simulation minus measurement on the training window.

        Every step-th sample, of the full model `params` with nonlinear `values` (plug-in
        inputs).
        """
        n = self.n_train
        da, db, amb = self.inputs(values)
        pos = act.simulate(params, da[:n], db[:n], self.data.dt, ambient_c=amb[:n]).position_rad
        sl = slice(self.burn_in, n, step)
        err = pos[sl] - self.data.position[sl]
        return err if self.keep is None else err[self.keep[sl]]

    def fatigued(self, params: act.ActuatorParams) -> bool:
        """Return True when the regressors carry functional fatigue (see `regressors`)."""
        return any(k in self.names for k in LINEAR_PARAMS) or params.fatigue_stroke != 0.0

    def inputs(self, values: dict) -> tuple:
        """(duty_a, duty_b, ambient) seen by the thermal model (after a plug-in hook)."""
        d = self.data
        if self.setup.input_hook is None:
            return d.duty_a, d.duty_b, self.amb
        da, db, amb = self.setup.input_hook(d.duty_a, d.duty_b, self.amb, values)
        return np.clip(da, 0.0, 1.0), np.clip(db, 0.0, 1.0), amb

    def solve(self, params: act.ActuatorParams, values: Optional[dict] = None,
              ref: Optional[PlayHysteresis] = None) -> 'LinearSolution':
        """
        Return the NNLS weights on the training window (a `LinearSolution`).

        values, ref: as in `regressors`. The residual is the forward one, p(X b) − y.
        """
        n = self.n_train
        sl = slice(self.burn_in, n, self.stride)
        X, state_lo, state_hi = self.regressors(params, n, sl, values, ref)
        y = self.data.position[sl]
        if self.keep is not None:   # the rest gaps between records carry no measurement
            X, y = X[self.keep[sl]], y[self.keep[sl]]
        # regress the angle before the sensor, p⁻¹(y); the residual is the forward one,
        # p(X b) − y, which the outer search minimises
        target = act.sensor_inverse(params, y)
        if self.direction < 0:   # the weights stay >= 0 on the hysteresis columns
            X[:, :self.grid.n_operators + 1] *= -1.0
        if any(k in self.names for k in LINEAR_PARAMS):
            # weights >= 0, each wire's fatigue drift within half the measured travel (beyond
            # that g_a − g_b with huge cancelling offsets fits start-up transients), offset free
            bound = 0.5 * float(np.ptp(self.data.position))
            m = X.shape[1] - 3
            lower = np.r_[np.zeros(m), -bound, -bound, -np.inf]
            upper = np.r_[np.full(m, np.inf), bound, bound, np.inf]
            b = box_ls(X, target, lower, upper)
        else:
            b = nnls_with_offset(X, target, free_cols=1)
        return LinearSolution(b, act.sensor_polynomial(params, X @ b) - y, state_lo, state_hi)

    def with_linear(self, params: act.ActuatorParams,
                    solution: 'LinearSolution') -> act.ActuatorParams:
        """Return ActuatorParams with the solution as normalised hysteresis + shaft gain."""
        g, m = self.grid, self.grid.n_operators
        b = solution.coef
        w, k1 = b[:m], b[m]
        if not np.all(np.isfinite(b)):
            raise ValueError('the fit diverged (non-finite weights); check the data and bounds')
        if self.linear_term:   # unbounded (classical) operator: no [0, 1] range to normalise to
            y_lo, stroke = 0.0, 1.0
        else:   # normalise so the contraction fraction spans [0, 1] over the states the
            # training window shows (over the whole bands, a large weight on an element that
            # barely moved in training would set a stroke far beyond the measured travel)
            y_lo, y_hi = PlayHysteresis(g.r, solution.state_lo, solution.state_hi, w, k1,
                                        0.0).output_range()
            stroke = max(y_hi - y_lo, 1e-9)
        h = PlayHysteresis(g.r, g.lo, g.hi, w / stroke, k1 / stroke, -y_lo / stroke)
        stroke *= self.direction
        # φ = φ0 + stroke (y_a − s_b y_b): the y0 shift enters through (1 − s_b), unless the
        # (fatigue) regressors already count the states from cold
        offset = b[-1]
        if not self.fatigued(params):
            offset -= stroke * h.y0 * (1.0 - params.stroke_ratio_b)
        drift = {}
        if len(b) == m + 4:
            drift = {'fatigue_offset_rad': b[m + 1], 'fatigue_offset_b_rad': b[m + 2]}
        return params.with_changes(hysteresis=h, stroke_rad=stroke, offset_rad=offset, **drift)

    def optimise(self, x0: dict, max_nfev: int, ref: Optional[PlayHysteresis] = None) -> tuple:
        """
        Return (values, cost) of the outer nonlinear least squares over the free parameters.

        The linear part is projected out at every trial; x0 holds the start values, `ref`
        is the hysteresis in the feedback path.
        """
        free = self.setup.free
        names = [k for k in self.names if k not in LINEAR_PARAMS]
        if not names:
            return {}, None
        lo = np.array([free[k][0] for k in names], float)
        hi = np.array([free[k][1] for k in names], float)
        x0 = np.clip(np.array([x0[k] for k in names], float), lo, hi)

        feedback = any(k in FEEDBACK_PARAMS for k in names)

        def residual(x: np.ndarray) -> np.ndarray:
            """Return the residual at the nonlinear parameter values `x` (in `names` order)."""
            trial = dict(zip(names, x))
            params = set_values(self.base, trial)
            sol = self.solve(params, trial, ref)
            if not feedback:
                return sol.residual
            # feedback effects: the regression saw the previous round's hysteresis in the
            # loop; score the model's own free-run simulation instead (thinned like the rows)
            return self.free_run_error(self.with_linear(params, sol), trial, self.stride)

        span = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(np.abs(x0), 1.0))
        sol = least_squares(residual, x0, bounds=(lo, hi), x_scale=span, diff_step=1e-3,
                            max_nfev=max_nfev, ftol=OUTER_TOL, xtol=OUTER_TOL)
        return dict(zip(names, sol.x)), sol.cost


def _settle(prob: _Problem, values: dict, ref: PlayHysteresis,
            steps: int = FIXED_POINT_STEPS) -> Settled:
    """
    Iterate the feedback fixed point at fixed nonlinear `values`, from the reference `ref`.

    The regression sees the hysteresis output (phase, stress, fatigue) through the
    reference, so the weights it returns are consistent only when they reproduce that
    reference. Each step is one simulation and one NNLS (far cheaper than a search round)
    and makes its model the next reference; returns the `Settled` step whose own
    simulation fits the training window best (its hysteresis is the reference to go on with).
    """
    nonlinear = set_values(prob.base, values)
    best = None
    for _ in range(steps):
        params = prob.with_linear(nonlinear, prob.solve(nonlinear, values, ref))
        ref = params.hysteresis
        err = float(np.mean(prob.free_run_error(params, values) ** 2))
        if best is None or err < best.mse:
            best = Settled(err, params, dict(values), params.hysteresis)
    return best


def _scan_tau(prob: _Problem, values: dict, ref: PlayHysteresis,
              factors: tuple = (0.6, 0.75, 0.9, 1.0, 1.15, 1.35, 1.6)) -> float:
    """
    Time constant with the lowest training error among `factors` x the current one.

    Within the bounds of tau_s. The error surface in τ has several basins on closed-loop
    data, and the coarse grid's optimum can sit in the wrong one.
    """
    bounds = prob.setup.free['tau_s']
    best = (np.inf, values['tau_s'])
    for f in factors:
        tau = float(np.clip(f * values['tau_s'], bounds[0], bounds[1]))
        trial = set_values(prob.base, dict(values, tau_s=tau))
        cost = float(np.sum(prob.solve(trial, values, ref).residual ** 2))
        best = min(best, (cost, tau))
    return best[1]


# ------------------------------------------------------------------------- dynamic stages
# fit_dynamic runs these stages; each takes the previous one's result as an argument and
# returns a small frozen record, so no stage depends on state another one left behind:
#   prepare -> Setup; input_range -> InputRange; fit_coarse -> GridFit;
#   refine_grid (GridFit -> GridFit, `refine` times); prune_grid -> grid;
#   fit_final -> Settled; score_fit -> DynamicFit


@dataclass(frozen=True)
class SearchOptions:
    """
    How thoroughly `fit_dynamic` searches.

    coarse/fine: (widths, centres) of the coarse grid and of the adaptive fine grid.
    coarse_alternatives: further coarse grids, each the start of a whole search of its own
    where the first fit is above NEAR_NOISE times the noise (`record_noise_rms`); the
    lowest training error among those that reach that replaces it. The fine grid follows
    the coarse fit's weights, so the coarse grid decides the basin.
    starts: the coarse multi-start, time constants as multiples of base.tau_s / 2.
    max_nfev: evaluations per outer search. rounds: alternations of search and feedback
    settling in the final stage. refine: passes of the adaptive fine grid (modified PI).
    """

    train_fraction: float = TRAIN_FRACTION
    coarse: tuple = (6, 10)
    coarse_alternatives: tuple = ((4, 8), (6, 14))
    fine: tuple = (14, 24)
    starts: tuple = (0.6, 2.0, 6.0)
    max_nfev: int = 40
    rounds: int = 3
    refine: int = 2


# upper bound of the fitted thermal time constant [s], raised for a slow wire up to
# MAX_TAU_S (`tau_bound`)
TAU_BOUND_S = 20.0
MAX_TAU_S = 60.0
TAU_BOUND_LAGS = 4.0
# first-order lags [s] through which `lag_correlations` correlates duty and position
LAG_TAUS_S = tuple(0.25 * 2.0 ** k for k in range(9))


@dataclass(frozen=True)
class Setup:
    """
    Stage 1 (`prepare`): the checked problem every later stage reads.

    free: {name: (lower, upper, initial)}; values: the starting values of the free
    parameters; start_tau: a previous fit's time constant is the one coarse start.
    """

    data: DynamicData
    base: act.ActuatorParams
    free: dict
    values: dict
    n_train: int
    burn_in: int
    input_hook: Optional[Callable] = None
    start_tau: bool = False
    # β of `tie_loop_width` (None: the grids' widths are free), see `fit_dynamic`
    loop_ratio: Optional[float] = None
    # sign of the stroke g: +1 when heating wire a raises the reading, −1 when the sensor
    # reads the other way (`lag_correlations`)
    direction: float = 1.0

    @property
    def feedback(self) -> bool:
        """Return True when a free parameter feeds the hysteresis back into its regressors."""
        return any(k in FEEDBACK_PARAMS for k in self.free)


@dataclass(frozen=True)
class InputRange:
    """Stage 2 (`input_range`): model temperatures the grids cover [°C], and the rest one."""

    lo: float
    hi: float
    rest: float


@dataclass(frozen=True)
class LinearSolution:
    """One regression (`_Problem.solve`): coefficients, residual, states regressed on."""

    coef: np.ndarray
    residual: np.ndarray
    state_lo: np.ndarray
    state_hi: np.ndarray


@dataclass(frozen=True)
class GridFit:
    """
    Stages 3-4 (`fit_coarse`, `refine_grid`): a grid with its fitted values.

    solution: the weights at `values`; shape: (widths, centres) of an adaptive grid
    (None for a regular one).
    """

    problem: _Problem
    values: dict
    solution: LinearSolution
    shape: Optional[tuple] = None

    @property
    def grid(self) -> PlayHysteresis:
        """Return the threshold grid of this stage."""
        return self.problem.grid


@dataclass(frozen=True)
class Settled:
    """`_settle` and `fit_final`: training MSE [rad²], model, its values, feedback reference."""

    mse: float
    params: act.ActuatorParams
    values: dict
    ref: PlayHysteresis


def prepare(data: DynamicData, free: Optional[dict] = None,
            base: Optional[act.ActuatorParams] = None, start: Optional[dict] = None,
            input_hook: Optional[Callable] = None,
            train_fraction: float = TRAIN_FRACTION,
            loop_ratio: Optional[float] = None) -> Setup:
    """
    Check the problem and fix what every stage shares: base model, bounds, split.

    The base's ambient defaults to the first measured ambient values and ambient_gain to 0
    (constant ambient) unless they are free; tau_s is always free. The first
    `train_fraction` of time trains (or the samples before `data.split`), after a burn-in
    of 1 s (at most a tenth of the training window).
    """
    if not isinstance(data, DynamicData):
        raise TypeError('data must be a DynamicData')
    if not 0.2 <= train_fraction < 1.0:
        raise ValueError(f'train_fraction must be in [0.2, 1), got {train_fraction}')
    base = act.ActuatorParams() if base is None else base
    free = dict(free or {})
    if data.ambient is not None and 'ambient_c' not in free:
        base = base.with_changes(ambient_c=float(np.mean(data.ambient[: max(1, len(data) // 50)])))
    if 'ambient_gain' not in free:   # the paper's model: constant ambient temperature
        base = base.with_changes(ambient_gain=0.0)
    n_train = data.default_split(train_fraction).start
    lags = lag_correlations(data, n_train)
    free.setdefault('tau_s', (0.2, tau_bound(lags), base.tau_s))
    for k, (lo, hi, x0) in free.items():
        if not lo <= x0 <= hi:
            raise ValueError(f'initial value of {k} ({x0}) outside its bounds [{lo}, {hi}]')
    if np.ptp(data.duty_a) + np.ptp(data.duty_b) < MIN_DUTY_EXCITATION:
        raise ValueError('too little excitation: the duties hardly vary, so the thermal and '
                         'hysteresis parameters cannot be identified')
    if np.ptp(data.position) <= 0:
        raise ValueError('too little excitation: the measured position is constant')
    burn_in = min(int(round(1.0 / data.dt)), n_train // 10)
    if SENSOR_TERMS & free.keys():
        base = _sensor_travel(base, data.position[:n_train][data.scored_mask()[:n_train]])
    values = {k: v[2] for k, v in free.items()}
    if start:
        values.update({k: v for k, v in start.items() if k in values})
    return Setup(data, base, free, values, n_train, burn_in, input_hook,
                 bool(start) and 'tau_s' in start, loop_ratio,
                 -1.0 if np.all(lags < 0.0) else 1.0)


def lag_correlations(data: DynamicData, n_train: int) -> np.ndarray:
    """
    Return the correlation of position and heating at each lag of LAG_TAUS_S.

    Heating: the duty difference d_a − d_b through the first-order lag of eq. (7) at that
    τ; over the training samples. A potentiometer can be mounted either way round, and the
    hysteresis weights are non-negative, so the stroke g carries the sign: −1 when the
    correlation is negative at every lag (`prepare`). Mixed signs are not evidence: a wire
    far slower than the lag, or a loop cycling around a delay, anticorrelates at short
    lags.
    """
    keep = data.scored_mask()[:n_train]
    y = data.position[:n_train][keep]
    out = np.zeros(len(LAG_TAUS_S))
    for i, tau in enumerate(LAG_TAUS_S):
        alpha = data.dt / (tau + data.dt)
        heat = lfilter([alpha], [1.0, alpha - 1.0], data.duty_a - data.duty_b)[:n_train][keep]
        if np.ptp(heat) > 0 and np.ptp(y) > 0:
            out[i] = np.corrcoef(heat, y)[0, 1]
    return out


def tau_bound(lags: np.ndarray) -> float:
    """
    Return the upper bound of the fitted τ [s]: TAU_BOUND_S, up to MAX_TAU_S for a slow wire.

    TAU_BOUND_LAGS times the lag that correlates most strongly (`lag_correlations`): a
    thick or sleeved wire cools over tens of seconds, and a bound below its τ holds the fit
    off its basin. A record that heats and cools correlates best near the wire's τ; a step
    or a ramp, whose response only rises, at a shorter lag (a quarter of τ on the
    spring-biased wire's step).
    """
    peak = LAG_TAUS_S[int(np.argmax(np.abs(lags)))]
    return float(np.clip(TAU_BOUND_LAGS * peak, TAU_BOUND_S, MAX_TAU_S))


def _sensor_travel(base: act.ActuatorParams, position: np.ndarray) -> act.ActuatorParams:
    """
    Return `base` with the sensor polynomial expanded about the measured travel.

    φc = the middle and h = half the range of the measured training positions (not the rest
    gaps between joined records), so its fitted terms are fractions of the travel on any rig
    and in any unit (`core.actuator.sensor_polynomial`).
    """
    lo, hi = float(np.min(position)), float(np.max(position))
    return base.with_changes(sensor_centre_rad=0.5 * (lo + hi),
                             sensor_half_span_rad=max(0.5 * (hi - lo), 1e-9))


def input_range(setup: Setup) -> InputRange:
    """
    Return the model temperature range the grids cover.

    From 2 K below the lowest ambient to the highest ambient plus the steady-state rise at
    the highest duty, gain_k · max duty; the rest temperature is the highest ambient.
    """
    data, base = setup.data, setup.base
    amb = data.ambient if data.ambient is not None else np.full(len(data), base.ambient_c)
    top_duty = max(data.duty_a.max(), data.duty_b.max())
    return InputRange(float(np.min(amb)) - 2.0, float(np.max(amb)) + base.gain_k * top_duty,
                      float(np.max(amb)))


# the coarse search starts once more this far above a time constant beyond all its starts,
# and keeps that start's fit if its squared training error is below this share
SLOW_START_FACTOR = 3.0
SLOW_START_GAIN = 0.8


def fit_coarse(setup: Setup, span: InputRange, kind: str, options: SearchOptions) -> GridFit:
    """
    Fit on a coarse grid over the whole range: the time constant and where the wire transforms.

    A multi-start over the time constant (`options.starts` x base.tau_s / 2), unless the
    setup names a previous fit's, which is then the one start. A time constant found above
    every start is searched again from SLOW_START_FACTOR times it (thick or sleeved wires
    cool over tens of seconds) while that fits better by SLOW_START_GAIN and finds a time
    constant above its own start.
    """
    values = dict(setup.values)
    coarse = tie_loop_width(play_grid(span.lo, span.hi, kind, *options.coarse), span.rest,
                            setup.loop_ratio)
    prob = _Problem(setup, close_major_loop(coarse, span.rest))
    ref = prob.grid
    if setup.feedback:   # a first reference, so the search sees the feedback at all
        ref = _settle(prob, values, ref).ref
    lower, upper = setup.free['tau_s'][:2]
    taus = ([values['tau_s']] if setup.start_tau else
            [float(np.clip(s * setup.base.tau_s / 2.0, lower, upper)) for s in options.starts])

    def from_tau(tau: float) -> tuple:
        trial = dict(values, tau_s=tau)
        return prob.optimise({k: trial[k] for k in setup.free}, options.max_nfev, ref)
    best = min((from_tau(t) for t in taus), key=lambda r: r[1])
    top = max(taus)
    # a slower wire than every start: once more from SLOW_START_FACTOR x beyond it, kept if
    # it fits clearly better (a misfit can drift to a long τ for a marginal gain)
    while not setup.start_tau and best[0]['tau_s'] > top and top < upper:
        top = min(SLOW_START_FACTOR * best[0]['tau_s'], upper)
        slower = from_tau(top)
        if slower[1] >= SLOW_START_GAIN * best[1]:
            break
        best = slower
    values.update(best[0])
    return GridFit(prob, values, prob.solve(set_values(setup.base, values), values, ref))


def refine_grid(setup: Setup, span: InputRange, kind: str, previous: GridFit,
                options: SearchOptions) -> GridFit:
    """
    Fit on a fine grid placed where the `previous` stage's weights are (modified PI).

    The coarse weights sit at a lag-distorted temperature when the dynamics are off (e.g.
    with unmodelled fast dynamics), so a second pass follows its own fit's weights; each
    pass re-scans τ and re-searches on the whole fine grid, whose optimum can lie in
    another basin than the coarse one. Classical PI: a regular fine grid.
    """
    values = dict(previous.values)
    shape = None
    if kind == 'modified':
        h = previous.problem.with_linear(set_values(setup.base, values),
                                         previous.solution).hysteresis
        states = previous.solution.state_hi - previous.solution.state_lo
        grid, shape = adaptive_grid(h, states, span.lo, span.hi, *options.fine)
        edge = heating_edge(h, states)
        grid = close_major_loop(tie_loop_width(grid, span.rest, setup.loop_ratio, edge),
                                span.rest)
    else:
        grid = play_grid(span.lo, span.hi, kind, *options.fine)
    prob = _Problem(setup, grid)
    ref = grid
    if setup.feedback:
        ref = _settle(prob, values, ref).ref
    values['tau_s'] = _scan_tau(prob, values, ref)
    values.update(prob.optimise(values, options.max_nfev, ref)[0])
    return GridFit(prob, values, prob.solve(set_values(setup.base, values), values, ref), shape)


def prune_grid(stage: GridFit) -> PlayHysteresis:
    """
    Keep the elements the stage's solution uses, and their grid neighbours.

    The nonlinear search (and every candidate effect after it) then works on a small basis.
    """
    return prune_unused(stage.grid, stage.solution.coef[:stage.grid.n_operators], stage.shape)


def fit_final(setup: Setup, grid: PlayHysteresis, values: dict,
              ref: Optional[PlayHysteresis], rounds: int, max_nfev: int) -> Settled:
    """
    Search the free parameters on `grid` from `values`; return the best model.

    With feedback effects the search alternates with settling the feedback fixed point
    (`rounds` times) and the best settled model wins; ref: the hysteresis in the feedback
    path at the start (default: the grid with zero weights).
    """
    prob = _Problem(setup, grid)
    ref = grid if ref is None else ref
    values = dict(values)
    best = None
    for _ in range(rounds if setup.feedback else 1):
        if setup.feedback:
            settled = _settle(prob, values, ref)
            ref = settled.ref
            best = settled if best is None or settled.mse < best.mse else best
        values.update(prob.optimise(values, max_nfev, ref)[0])
        if setup.feedback:
            settled = _settle(prob, values, ref)
            ref = settled.ref
            best = settled if settled.mse < best.mse else best
        else:
            params = set_values(setup.base, values)
            best = Settled(0.0, prob.with_linear(params, prob.solve(params, values, ref)),
                           dict(values), ref)
    return best


def score_fit(setup: Setup, grid: PlayHysteresis, best: Settled) -> DynamicFit:
    """
    Narrow the bands of the best model, simulate it free-run and score both windows.

    The linear parameters solved with the weights join the fitted values.
    """
    data, n_train = setup.data, setup.n_train
    params = best.params
    values = dict(best.values)
    values.update({k: getattr(params, k) for k in LINEAR_PARAMS})
    values = {k: float(values[k]) for k in setup.free}
    da, db, amb = _Problem(setup, grid).inputs(values)
    params = narrow_bands(params, da[:n_train], db[:n_train], amb[:n_train], data.dt)
    traj = act.simulate(params, da, db, data.dt, ambient_c=amb)
    pred, y = traj.position_rad, data.position
    n_par = int(np.count_nonzero(params.hysteresis.w)) + 3 + len(setup.free)
    train, val = data.split_masks(Split(n_train, setup.burn_in))
    span = data.span()
    return DynamicFit(params, values, scores(y[train], pred[train], span),
                      scores(y[val], pred[val], span) if val.any() else None, pred, traj,
                      n_train, setup.burn_in, n_par, grid)


def fit_dynamic(data: DynamicData, free: Optional[dict] = None, kind: str = 'modified',
                base: Optional[act.ActuatorParams] = None,
                grid: Optional[PlayHysteresis] = None, start: Optional[dict] = None,
                input_hook: Optional[Callable] = None, ref: Optional[PlayHysteresis] = None,
                options: SearchOptions = SearchOptions(),
                loop_ratio: Optional[float] = None) -> DynamicFit:
    """
    Fit the actuator model to a dynamic run by free-run simulation error.

    data: `DynamicData`. free: {ActuatorParams field or 'tau_s': (lower, upper, initial)}
    of nonlinear parameters to fit besides the hysteresis weights (by default only the
    thermal time constant tau_s). kind: 'modified' (eq. 6) or 'classical' (eq. 5) PI.
    base: starting ActuatorParams (Flexinol defaults; its G and ambient stay fixed, see
    `prepare`). grid/start: reuse a previous fit's threshold grid and warm start values
    (diagnose does, so candidates are compared on equal terms); with no grid, the coarse
    and fine grid stages run first. input_hook(duty_a, duty_b, ambient, values) ->
    (duty_a, duty_b, ambient): plug-in transform of the inputs with its own free
    parameters (names not in ActuatorParams). ref: hysteresis on `grid` used in the
    feedback path of the first round (default: the grid with zero weights, i.e. no
    feedback until the first weights are known). options: `SearchOptions`; with no grid,
    every stage runs from its coarse grid and, where that fit is above NEAR_NOISE times the
    noise, from each of its coarse alternatives (`fit_on_coarse_grid`), of which the
    lowest training error within that bar wins. loop_ratio: None, or β of `tie_loop_width`
    (the descending branch tied to the ascending one, for training data that never shows
    the wire cooling through its transformation; the workbench passes
    `flexinol_loop_ratio()` then). The fitted
    elements' bands are narrowed to the states they took in the training window
    (`narrow_bands`). Returns a `DynamicFit` scored by free-run error on training and
    held-out data.
    """
    setup = prepare(data, free, base, start, input_hook, options.train_fraction, loop_ratio)
    if grid is not None:
        best = fit_final(setup, grid, setup.values, ref, options.rounds, options.max_nfev)
        return score_fit(setup, grid, best)
    fit = fit_on_coarse_grid(setup, kind, options, options.coarse, ref)
    near_noise = NEAR_NOISE * record_noise_rms(data)
    if fit.train['rmse'] <= near_noise:
        return fit
    others = [fit_on_coarse_grid(setup, kind, options, coarse, ref)
              for coarse in options.coarse_alternatives]
    # among misfits a lower training error does not predict better held out (an effect is
    # missing, and each basin misses it differently): only fits that reach the noise count
    at_noise = [f for f in others if f.train['rmse'] <= near_noise]
    return min(at_noise, key=lambda f: f.train['rmse']) if at_noise else fit


def fit_on_coarse_grid(setup: Setup, kind: str, options: SearchOptions, coarse: tuple,
                       ref: Optional[PlayHysteresis] = None) -> DynamicFit:
    """
    Run every stage from a coarse grid of `coarse` (widths, centres); return the scored fit.

    fit_coarse, `options.refine` passes of refine_grid (one for classical PI), prune_grid,
    fit_final and score_fit (the stages of `fit_dynamic`).
    """
    options = replace(options, coarse=coarse)
    span = input_range(setup)
    stage = fit_coarse(setup, span, kind, options)
    for _ in range(options.refine if kind == 'modified' else 1):
        stage = refine_grid(setup, span, kind, stage, options)
    grid = prune_grid(stage)
    best = fit_final(setup, grid, stage.values, ref, options.rounds, options.max_nfev)
    return score_fit(setup, grid, best)
