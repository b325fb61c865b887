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
Paper figures rendered from the core code (`model_figures --out DIR`).

Fig. 2 major loop (cosine eqs. 1-2 and Ikuta), Fig. 5 Preisach (231 relays), Figs. 8-9
classical Prandtl-Ishlinskii (8 backlash elements, total h = 1, K = 1), Fig. 11 modified
PI (8 backlash-with-saturation elements), the thermal step response of eq. (7) (exact
discretisation against a fine ODE reference) and the fit to measured morphing-wing loops.
Writes PNGs and figures.json (the real-data NRMSE figures).
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import Any, Dict, Optional, Sequence, Tuple, TYPE_CHECKING

import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from .core import static_fit  # noqa: E402
from .core.hysteresis import (ModifiedPrandtlIshlinskii, PrandtlIshlinskii,  # noqa: E402
                              PreisachModel)
from .core.major_loop import MajorLoopHysteresis  # noqa: E402
from .core.thermal import thermal_step  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

# the measured loops ship in the workspace's shared/ folder beside the repository
REAL_DATA = str(Path(os.environ.get('SMA_SHARED_DIR',
                                    Path(__file__).resolve().parents[2] / 'shared'))
                / 'data' / 'real' / 'morphing_wing_sma_loops.csv')
N_PI = 8


def decaying_sine(amplitude: float = 1.0, cycles: int = 6, n: int = 3000,
                  floor: float = 0.15) -> np.ndarray:
    """Return a sine decaying linearly from `amplitude` to floor*amplitude (inner loops)."""
    t = np.linspace(0.0, 1.0, n)
    return amplitude * (1.0 - (1.0 - floor) * t) * np.sin(2 * np.pi * cycles * t)


def paper_pi() -> PrandtlIshlinskii:
    """Return the classical PI of Figs. 8-9: h_i = i/8, K_i = 1/8, i = 1..8 (total h = K = 1)."""
    h = np.arange(1, N_PI + 1) / N_PI
    return PrandtlIshlinskii(h, np.full(N_PI, 1.0 / N_PI))


def paper_modified_pi(u_m: float = 2.5, k1_ratio: float = 0.1) -> ModifiedPrandtlIshlinskii:
    """
    Return the modified PI of Fig. 11.

    8 elements of eq. (6), h_i = i/8, K_i = 1/8, K1 = 0.1 K, all saturating at u_m
    (M = u_m (K − K1) − K h from the paper's u_m formula).
    """
    h = np.arange(1, N_PI + 1) / N_PI
    K = np.full(N_PI, 1.0 / N_PI)
    K1 = k1_ratio * K
    M = u_m * (K - K1) - K * h
    return ModifiedPrandtlIshlinskii.from_paper(M, K, K1, h)


def fig_main_loop(ax: Axes) -> None:
    """Draw Fig. 2: length vs temperature, heating 20 -> 100 °C and back, cosine and Ikuta laws."""
    up = np.linspace(20.0, 100.0, 400)
    u = np.concatenate([up, up[::-1]])
    for kind, style in (('cosine', '-'), ('ikuta', '--')):
        y = MajorLoopHysteresis(68.0, 78.0, 52.0, 42.0, y0=1.0, kind=kind).simulate(u)
        ax.plot(u, y, style, label=kind)
    for t, name in ((68, 'As'), (78, 'Af'), (52, 'Ms'), (42, 'Mf')):
        ax.axvline(t, color='0.8', lw=0.8)
        ax.text(t, 1.03, name, ha='center', fontsize=8)
    ax.set(xlabel='temperature u [°C]', ylabel='length y / y0',
           title='Fig. 2: main hysteresis loop (eqs. 1-2, Ikuta)')
    ax.legend()


def fig_preisach(ax: Axes) -> None:
    """Draw Fig. 5: Preisach operator, 231 relays on [-1, 1], weights 1, decaying sine input."""
    model = PreisachModel.grid(21, -1.0, 1.0, mu=1.0)
    u = decaying_sine(1.1)
    ax.plot(u, model.simulate(u), lw=0.8)
    ax.set(xlabel='u', ylabel='y', title=f'Fig. 5: Preisach, {len(model.alpha)} relays')


def fig_pi(ax_major: Axes, ax_inner: Axes) -> None:
    """Draw Figs. 8-9: classical PI, major loop and inner loops of a decaying sine."""
    model = paper_pi()
    u = 3.0 * np.sin(np.linspace(0, 4 * np.pi, 2000))
    ax_major.plot(u, model.simulate(u))
    ax_major.set(xlabel='u', ylabel='y', title='Fig. 8: Prandtl-Ishlinskii, 8 backlash elements')
    u = decaying_sine(3.0)
    ax_inner.plot(u, model.simulate(u), lw=0.8)
    ax_inner.set(xlabel='u', ylabel='y', title='Fig. 9: inner loops, 8 elements')


def fig_modified_pi(ax: Axes) -> None:
    """Draw Fig. 11: modified PI (eq. 6) with saturation beyond u_m."""
    model = paper_modified_pi()
    u = decaying_sine(4.0, floor=0.2)
    ax.plot(u, model.simulate(u), lw=0.8)
    for s in (-2.5, 2.5):
        ax.axvline(s, color='0.8', lw=0.8)
    ax.set(xlabel='u', ylabel='y',
           title='Fig. 11: modified PI, 8 saturated elements (|u| > u_m = 2.5: slope ΣK1)')


def thermal_response(dt: float = 0.25, t_end: float = 12.0, tau: float = 2.0,
                     tau_fast: float = 0.3, theta_amb: float = 22.0,
                     gain: float = 70.0) -> Tuple[np.ndarray, ...]:
    """
    Compute the step response of eq. (7): exact step (7d)/(7f) at dt, and solve_ivp (reference).

    Returns (t, exact_1lag, exact_2lag, t_ref, ref_1lag, ref_2lag).
    """
    n = int(round(t_end / dt))
    t = np.arange(n + 1) * dt
    out = np.empty((2, n + 1))
    for j, tf in enumerate((0.0, tau_fast)):
        theta, q = theta_amb, 0.0
        out[j, 0] = theta
        for k in range(n):
            theta, q = thermal_step(theta, q, theta_amb, gain, dt, tau, tf)
            out[j, k + 1] = theta
    t_ref = np.linspace(0, t_end, 600)
    one = solve_ivp(lambda _, x: [(-(x[0] - theta_amb) + gain) / tau], (0, t_end), [theta_amb],
                    t_eval=t_ref, rtol=1e-10, atol=1e-10).y[0]
    two = solve_ivp(lambda _, x: [(-(x[0] - theta_amb) + x[1]) / tau, (gain - x[1]) / tau_fast],
                    (0, t_end), [theta_amb, 0.0], t_eval=t_ref, rtol=1e-10, atol=1e-10).y[0]
    return t, out[0], out[1], t_ref, one, two


def fig_thermal(ax: Axes) -> None:
    """Draw the thermal step response: exact discretisation (dt = 0.25 s) vs fine reference."""
    t, e1, e2, tr, r1, r2 = thermal_response()
    ax.plot(tr, r1, 'C0-', label='reference, T = 2 s')
    ax.plot(t, e1, 'C0o', ms=3, label='exact step (7d), dt = 0.25 s')
    ax.plot(tr, r2, 'C1-', label='reference, T = 2 s, τ = 0.3 s')
    ax.plot(t, e2, 'C1s', ms=3, label='exact step (7f)')
    ax.set(xlabel='t [s]', ylabel='θ [°C]', title='Eq. (7): step of G d = 70 K from 22 °C')
    ax.legend(fontsize=7)


def load_real(path: str = REAL_DATA) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (curve, voltage [V], deflection [mm]) of the morphing-wing CSV ('#' comments)."""
    with open(path) as f:
        rows = [line.strip().split(',') for line in f if line.strip() and not line.startswith('#')]
    data = np.array(rows[1:], dtype=float)
    return data[:, 0].astype(int), data[:, 1], data[:, 2]


def fig_real(axes: Sequence[Axes], path: str = REAL_DATA) -> Dict[str, Dict[str, float]]:
    """
    Fit and draw classical (nonneg=False) and modified PI on the measured loops.

    Even curves train, odd curves validate; return the NRMSE figures per kind.
    """
    curve, u, y = load_real(path)
    result = {}
    for ax, kind, nonneg in zip(axes, ('classical', 'modified'), (False, True)):
        fit = static_fit.fit_static(u, y, curve, kind=kind, nonneg=nonneg)
        pred = dict(fit.prediction)
        for c in np.unique(curve):
            sel = curve == c
            colour = 'C0' if c % 2 == 0 else 'C3'
            ax.plot(u[sel], y[sel], '.', color=colour, ms=2)
            ax.plot(u[sel], pred[c], '-', color=colour, lw=0.8)
        result[kind] = {'train_nrmse': fit.train['nrmse'],
                        'validation_nrmse': fit.validation['nrmse'],
                        'validation_fit_percent': fit.validation['fit_percent']}
        ax.set(xlabel='voltage [V]', ylabel='deflection [mm]',
               title=f'{kind} PI: NRMSE train {100 * fit.train["nrmse"]:.1f} %, '
                     f'validation {100 * fit.validation["nrmse"]:.1f} %')
        ax.plot([], [], 'C0-', label='even curves (train)')
        ax.plot([], [], 'C3-', label='odd curves (validation)')
        ax.legend(fontsize=7)
    return result


def _save(fig: Figure, out: str, name: str) -> str:
    """Write `fig` as out/name (PNG) and close it; return the path."""
    path = os.path.join(out, name)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def render(out: str, data_path: str = REAL_DATA) -> Dict[str, Any]:
    """Render every figure into directory `out`; return the figures.json content."""
    os.makedirs(out, exist_ok=True)
    files = []
    for name, draw in (('fig02_main_loop.png', fig_main_loop),
                       ('fig05_preisach.png', fig_preisach),
                       ('fig11_modified_pi.png', fig_modified_pi),
                       ('thermal_step.png', fig_thermal)):
        fig, ax = plt.subplots(figsize=(6, 4.5))
        draw(ax)
        files.append(_save(fig, out, name))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    fig_pi(*axes)
    files.append(_save(fig, out, 'fig08_09_prandtl_ishlinskii.png'))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    real = fig_real(axes, data_path)
    files.append(_save(fig, out, 'real_data_fit.png'))
    summary = {'real_data': {'file': data_path, **real},
               'figures': [os.path.basename(f) for f in files]}
    with open(os.path.join(out, 'figures.json'), 'w') as f:
        json.dump(summary, f, indent=2)
    return summary


def main(argv: Optional[Sequence[str]] = None) -> None:
    """Run the console script `model_figures [--out DIR] [--data CSV]`."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--out', default='runs/figures', help='output directory')
    parser.add_argument('--data', default=REAL_DATA, help='morphing-wing loops CSV')
    args = parser.parse_args(argv)
    summary = render(args.out, args.data)
    for kind, s in summary['real_data'].items():
        if isinstance(s, dict):
            print(f'{kind}: validation NRMSE {100 * s["validation_nrmse"]:.2f} %')
    print(f'wrote {len(summary["figures"])} figures and figures.json to {args.out}')


if __name__ == '__main__':
    main()
