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
Measure how well a physically parametrised hysteresis loop fits the real rig, with timings.

    .venv/bin/python benchmarks/bench_loop_families.py [--dir DIR]

The question: could a loop of a few parameters replace the base model's free weights, so that
a static distortion has nowhere to hide? Only if it fits a real wire about as well, since
diagnose names any gain of 20 % or more. All three measured records are fitted at once
(training error, NRMSE over the measured range) by:

1. `sma-model fit` (the base model: adaptive grid, about 90 free weights >= 0);
2. free weights >= 0 on a uniform 12 x 48 grid of saturated plays (NNLS; the thermal model
   of fit 1, its time constant τ);
3. parametrised densities over the same grid (τ refitted with them; stroke and offset
   linear). An element of half-width r and band [lo, hi] rises at the heating edge
   e = (lo + hi)/2 + r and falls 2 r lower, so a density over (e, r) is a major loop:
   - `gauss`: w ∝ N(e; μ_e, σ_e) N(r; μ_r, σ_r), the transformation temperature, the width of
     each branch and the loop's half-width (As, Af, Ms, Mf in other words);
   - `skew`: the same with a skew-normal edge density (the branches' asymmetry);
   - `mix2`: two edge components (a two-stage transformation, e.g. via the R-phase);
4. `gauss` with one thermal effect of the catalog each (latent heat, convection, phase
   resistance), the whole model in the core kernel: does an effect close the gap?
"""
import argparse
from functools import partial
from pathlib import Path
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # as `sma-model` runs
keep_freed_memory()

import numpy as np  # noqa: E402, I100
from scipy.optimize import least_squares, nnls  # noqa: E402
from scipy.special import ndtr  # noqa: E402
from sma_actuator.core import actuator as act  # noqa: E402
from sma_actuator.core.hysteresis import PlayHysteresis  # noqa: E402
from sma_actuator.core.identification import set_values  # noqa: E402
from sma_actuator.core.play_grids import play_grid  # noqa: E402
from sma_actuator.workbench.crossval import all_records  # noqa: E402
from sma_actuator.workbench.data import load_data  # noqa: E402
from sma_actuator.workbench.engine import fit_model  # noqa: E402

NAMES = ('square_a', 'step_a', 'ramp_a')
ROW_STEP = 4   # every 4th sample (25 Hz) in the density fits: the same error, 4 x faster
# thermal effects of the catalog that reshape the loop in time: (lower, upper, starts)
THERMAL_EFFECTS = {'latent_heat_k': (0.0, 30.0, (1.0, 5.0)),
                   'convection_exponent': (0.0, 1.0, (0.1, 0.3)),
                   'phase_kappa': (0.0, 1.0, (0.1, 0.3))}


def gaussian(x, mean, sd):
    """Return the unnormalised normal density exp(−((x − mean)/sd)² / 2)."""
    return np.exp(-0.5 * ((x - mean) / sd) ** 2)


def families(edge, r):
    """Return {name: (density(q) over the grid, lower bounds, upper bounds)} in kelvin."""
    return {
        'gauss': lambda q: gaussian(edge, q[0], q[1]) * gaussian(r, q[2], q[3]),
        'skew': lambda q: (gaussian(edge, q[0], q[1]) * ndtr(q[4] * (edge - q[0]) / q[1])
                           * gaussian(r, q[2], q[3])),
        'mix2': lambda q: ((gaussian(edge, q[0], q[1]) + q[5] * gaussian(edge, q[4], q[6]))
                           * gaussian(r, q[2], q[3])),
    }


class LoopProblem:
    """Training residual of y = offset + stroke · (features(τ) @ w) on the joined records."""

    def __init__(self, data, params, grid):
        """Hold the records, the fitted base model's parameters and the element grid."""
        self.data, self.params, self.grid = data, params, grid
        self.y = data.position[::ROW_STEP]
        self.keep = data.scored_mask()[::ROW_STEP]
        self._tau, self._features = None, None

    def features(self, tau_s):
        """Return the element states along the temperature the thermal model gives with τ."""
        if tau_s != self._tau:
            d = self.data
            run = act.simulate(set_values(self.params, {'tau_s': tau_s}), d.duty_a, d.duty_b,
                               d.dt)
            self._tau, self._features = tau_s, self.grid.features(run.theta_a_c)[::ROW_STEP]
        return self._features

    def residual(self, density, x):
        """Return the model minus the measurement [mm] at the kept rows, x = (τ, density q)."""
        return self._fitted_residual(self.features(x[0]) @ _weights(density, x[1:]))

    def _fitted_residual(self, contraction):
        """Return offset + stroke · contraction − measurement [mm], both solved linearly."""
        a = np.c_[contraction, np.ones_like(contraction)][self.keep]
        coef, *_ = np.linalg.lstsq(a, self.y[self.keep], rcond=None)
        return a @ coef - self.y[self.keep]

    def residual_with(self, density, names, x):
        """
        Return the residual [mm] of the loop with thermal effects, x = (τ, q, effect values).

        The whole model runs in the core kernel: a feedback effect (latent heat, phase
        resistance) moves the temperature with the contraction, so the element states are
        not fixed features any more.
        """
        w = _weights(density, x[1:5])
        g = self.grid
        loop = PlayHysteresis(g.r, g.lo, g.hi, w, 0.0, -float(w @ g.lo))   # cold: 0
        values = dict(zip(names, x[5:]), tau_s=x[0])
        model = set_values(self.params, values)
        model = model.with_changes(hysteresis=loop, stroke_rad=1.0, offset_rad=0.0)
        d = self.data
        run = act.simulate(model, d.duty_a, d.duty_b, d.dt)
        return self._fitted_residual(run.y_a[::ROW_STEP])


def _weights(density, q):
    """Return the density's weights over the grid at parameters q, summing to 1."""
    w = density(q)
    return w / max(w.sum(), 1e-300)


def fit_family(residual, starts, lower, upper):
    """Return the best least-squares fit of residual(x) over several starts."""
    best = None
    span = np.asarray(upper) - np.asarray(lower)
    for x0 in starts:
        sol = least_squares(residual, np.clip(x0, lower, upper),
                            bounds=(lower, upper), diff_step=1e-3, x_scale=0.1 * span)
        if best is None or sol.cost < best.cost:
            best = sol
    return best


def main():
    """Print the training error of free weights and of each parametrised loop."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--dir', default='../shared/data/real/spring_biased_wire')
    args = ap.parse_args()
    data = all_records([(n, load_data(Path(args.dir) / f'{n}.csv')) for n in NAMES])
    keep = data.scored_mask()
    full_range = float(np.ptp(data.position[keep]))

    def show(name, rmse, took, extra=''):
        print(f'{name:<34} {100 * rmse / full_range:6.2f} % {rmse:7.3f} mm {took:7.1f} s  {extra}')

    print(f'training error on all three records (NRMSE over {full_range:.1f} mm)')
    started = time.perf_counter()
    base = fit_model(data)
    p = base.params
    error = (base.prediction - data.position)[keep]
    show('1. sma-model fit (free weights)', np.sqrt(np.mean(error ** 2)),
         time.perf_counter() - started, f'{np.count_nonzero(p.hysteresis.w)} weights, '
         f'τ {p.tau_s:.2f} s')
    lo, hi = p.ambient_c - 2.0, p.ambient_c + p.gain_k * float(np.max(data.duty_a)) + 5.0
    grid = play_grid(lo, hi, 'modified', 12, 48)
    problem = LoopProblem(data, p, grid)

    started = time.perf_counter()
    f = problem.features(p.tau_s)
    # the offset is sign-free: the difference of two non-negative columns
    a = np.c_[f, np.ones(len(f)), -np.ones(len(f))][problem.keep]
    coef, _ = nnls(a, problem.y[problem.keep], maxiter=50 * a.shape[1])
    rmse = float(np.sqrt(np.mean((a @ coef - problem.y[problem.keep]) ** 2)))
    show('2. free weights, uniform grid', rmse, time.perf_counter() - started,
         f'{np.count_nonzero(coef[:-2])} weights of {grid.n_operators}')

    span = hi - lo
    edge = 0.5 * (grid.lo + grid.hi) + grid.r
    shapes = families(edge, grid.r)
    lower = [0.2, lo, 0.005 * span, 0.0, 0.005 * span]
    upper = [20.0, hi, 0.5 * span, 0.4 * span, 0.3 * span]
    starts = [[p.tau_s, m, 0.05 * span, r, 0.05 * span]
              for m in np.linspace(lo + 0.3 * span, hi - 0.1 * span, 4)
              for r in (0.05 * span, 0.15 * span)]
    extra = {'gauss': ([], [], [[]]),
             'skew': ([-20.0], [20.0], [[-3.0], [0.0], [3.0]]),
             'mix2': ([lo, 0.0, 0.005 * span], [hi, 5.0, 0.5 * span],
                      [[-0.1 * span, 0.3, 0.03 * span], [0.1 * span, 0.3, 0.03 * span]])}
    gauss = None
    for i, (name, density) in enumerate(shapes.items(), 3):
        add_lo, add_hi, add_x0 = extra[name]
        if gauss is None:
            x0s = starts
        else:   # grown from the gauss fit: the extra edge component starts beside its mean
            x0s = [list(gauss) + ([gauss[1] + x[0]] + x[1:] if name == 'mix2' else x)
                   for x in add_x0]
        started = time.perf_counter()
        sol = fit_family(partial(problem.residual, density), x0s, lower + add_lo,
                         upper + add_hi)
        if gauss is None:
            gauss = sol.x
        rmse = float(np.sqrt(np.mean(sol.fun ** 2)))
        show(f'{i}. {name} ({len(sol.x) + 2} parameters)', rmse, time.perf_counter() - started,
             f'τ {sol.x[0]:.2f} s, μ_e {sol.x[1]:.1f} °C, σ_e {sol.x[2]:.2f} K, '
             f'μ_r {sol.x[3]:.2f} K, σ_r {sol.x[4]:.2f} K')
    for i, (name, (lo_e, hi_e, starts_e)) in enumerate(THERMAL_EFFECTS.items(), 6):
        started = time.perf_counter()
        sol = fit_family(partial(problem.residual_with, shapes['gauss'], [name]),
                         [list(gauss) + [x] for x in starts_e], lower + [lo_e],
                         upper + [hi_e])
        show(f'{i}. gauss + {name}', float(np.sqrt(np.mean(sol.fun ** 2))),
             time.perf_counter() - started, f'τ {sol.x[0]:.2f} s, {name} {sol.x[5]:.3g}')
    return 0


if __name__ == '__main__':
    np.seterr(all='ignore')
    raise SystemExit(main())
