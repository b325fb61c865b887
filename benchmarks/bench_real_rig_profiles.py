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
How far apart the heating laws that fit the measured wire alike predict other duty profiles.

    .venv/bin/python benchmarks/bench_real_rig_profiles.py [--jobs 0]
        [--dir ../shared/data/real/spring_biased_wire]

The three shared records heat at one duty level (84 % of the heated time at 0.2), so the
heating law is not identified there (docs/workbench.md, "Records at one duty level"). This
fits the base model and the base + each catalog effect on the heating law
(`Effect.heating_law`) on all three, as `sma-model fit A B C [--add E]` does, and the
same laws with their parameter held at a size a real wire may have (`PINNED`), and prints
each fit's training NRMSE [%]. Then it predicts duty profiles the rig's owners ran too
(the source repository lists squares at duty 0.1 and 0.2, on at 10 s and off at 15 s or
30 s, and a triangle; steps are added): per fit and profile, the RMS and largest difference
from the base model's prediction [mm], each prediction taken from its own rest. A small
spread says the three records fix the answer whichever law is true; a large one says which
profile to record before trusting the model there. A law held at its size that fits the
records clearly worse is ruled out by them. It is no score against measurements (none
exist for these profiles here).
"""
import argparse
from pathlib import Path
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` runs: the same fits, the same figures
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)

import numpy as np  # noqa: E402, I100
from sma_actuator.workbench.crossval import all_records, fit_all  # noqa: E402
from sma_actuator.workbench.data import load_data, make_dynamic  # noqa: E402
from sma_actuator.workbench.effects import CATALOG, is_builtin  # noqa: E402

NAMES = ('square_a', 'step_a', 'ramp_a')
DT_S = 0.01
LENGTH_S = 70.0
# (label, effects, pinned parameters) of the laws held at a size a wire may have: free
# convection h ~ ΔT^0.25 (laminar, a thin horizontal cylinder), a resistance 10 % apart
# between the phases either way, a 0.5 s second thermal node, a current limit that flattens
# the power halfway up the duty range used
PINNED = (('convection n = 0.25', ('convection',), {'convection_exponent': 0.25}),
          ('phase κ = +0.1', ('phase_resistance',), {'phase_kappa': 0.1}),
          ('phase κ = -0.1', ('phase_resistance',), {'phase_kappa': -0.1}),
          ('fast lag 0.5 s', ('fast_dynamics',), {'tau_fast_s': 0.5}),
          ('limit at duty 0.1', ('current_limit',),
           {'duty_limit': 0.1, 'duty_limit_sharpness': 6.0}))


def profiles():
    """Return {name: duty_a over LENGTH_S at DT_S}: squares, a triangle and steps."""
    t = np.arange(0.0, LENGTH_S, DT_S)
    out = {f'square {u:g}, 10-{off:g} s': np.where((t >= 10) & (t < off), u, 0.0)
           for u in (0.1, 0.2) for off in (15.0, 30.0)}
    out['triangle 0.2, 5-45 s'] = 0.2 * np.clip(np.minimum(t - 5, 45 - t) / 20, 0, 1)
    out.update({f'step {u:g} at 10 s': np.where(t >= 10, u, 0.0) for u in (0.1, 0.15)})
    return t, out


def variants():
    """Return [(label, effects, pinned)]: the base, each heating law free, then PINNED."""
    laws = [name for name, eff in CATALOG.items() if is_builtin(name) and eff.heating_law]
    return ([('base', (), None)] + [(f'{e} (free)', (e,), None) for e in laws]
            + list(PINNED))


def main():
    """Print the fits' training NRMSE and the spread of their predictions per profile."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--dir', default='../shared/data/real/spring_biased_wire')
    ap.add_argument('--jobs', type=int, default=0)
    args = ap.parse_args()
    data = all_records([(n, load_data(Path(args.dir) / f'{n}.csv')) for n in NAMES])
    labels, tasks = zip(*[(label, (data, effects, None, pinned))
                          for label, effects, pinned in variants()])
    started = time.perf_counter()
    fits = dict(zip(labels, fit_all(list(tasks), args.jobs)))
    took = time.perf_counter() - started
    unit = data.position_unit
    print(f'{len(fits)} fits on the three records: {took:.1f} s; measured range '
          f'{data.span():.2f} {unit}')
    t, duties = profiles()
    travel = {}
    for label, duty in duties.items():
        record = make_dynamic(label, {'time': t, 'duty_a': duty, 'duty_b': 0.0 * duty,
                                      'position': np.zeros_like(t)}, unit=unit)
        travel[label] = {n: f.simulate(record) for n, f in fits.items()}
    print(f'\nRMS / largest difference from the base prediction [{unit}], each from its rest')
    print(f'{"fit":<26} {"training":>8}  ' + ' '.join(f'{p:>18}' for p in duties))
    for name, fit in fits.items():
        cells = []
        for label in duties:
            y, base = travel[label][name], travel[label]['base']
            diff = (y - y[0]) - (base - base[0])
            cells.append(f'{np.sqrt(np.mean(diff ** 2)):8.2f} / {np.max(np.abs(diff)):6.2f}')
        print(f'{name:<26} {100 * fit.train["nrmse"]:6.2f} %  ' + ' '.join(cells))
    peaks = [np.ptp(travel[label]['base']) for label in duties]
    print(f'{"base travel [" + unit + "]":<36} ' + ' '.join(f'{p:18.2f}' for p in peaks))
    print('\nfitted values: ' + '; '.join(
        f'{name}: ' + ', '.join(f'{k} = {v:.4g}' for k, v in fit.values.items())
        for name, fit in fits.items()))
    return 0


if __name__ == '__main__':
    np.seterr(all='ignore')
    raise SystemExit(main())
