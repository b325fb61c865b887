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
`sma-model diagnose` on wires whose loop the PI base cannot follow: the paper's major-loop law.

Both simulators of the other benchmarks have congruent minor loops (play operators,
Preisach), as the PI base does. Here each wire follows the paper's eqs. (1)-(2), the cosine
law, or Ikuta's sigmoid, with the Liang-Rogers rule that scales a branch through its
reversal point (`core.major_loop.MajorLoopHysteresis`): a minor cycle that stays within the
transformation band transforms a little more on each repetition, which no sum of play
operators does. Thermal model: C dθ/dt = G d − hA (θ − θa), G 170 K at full duty over hA,
τ 1.5 s, θa 22 °C; loop As 65, Af 80, Ms 52, Mf 38 °C; shaft [rad] = stroke (ξ_b − ξ_a),
1 rad per full transformation; 1 ms steps, 40 Hz samples, noise 0.002 rad, a 12-bit ADC over
±1.2 rad; the rich simulator's open-loop duty sequences. Records: each law with no hidden
effect (the null), with a 0.3 s transport delay of the duty, and with a second thermal node
(the duty's heat reaches the wire through a 0.35 s lag, the catalog's `fast_dynamics`).

    python benchmarks/bench_major_loop_law.py [--duration 480] [--seed 300] [--jobs 2]
"""
import argparse
from pathlib import Path
import sys
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` and the record workers run
keep_freed_memory()
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))

import numpy as np  # noqa: E402, I100
from scipy.signal import lfilter  # noqa: E402

from sma_actuator.core.identification import DynamicData  # noqa: E402
from sma_actuator.core.major_loop import MajorLoopHysteresis  # noqa: E402
from sma_actuator.workbench.diagnosis import diagnose  # noqa: E402
from sma_actuator.workbench.engine import noise_floor  # noqa: E402
from support.parallel import imap_on_cores  # noqa: E402
from support.richsim_excitation import open_loop_duty  # noqa: E402

CMD_DT_S, STEP_S, RATE_HZ = 0.025, 1e-3, 40.0
TAU_S, GAIN_K, AMBIENT_C = 1.5, 170.0, 22.0
LOOP_C = (65.0, 80.0, 52.0, 38.0)        # As, Af, Ms, Mf [°C]
NOISE_RAD, ADC_LSB_RAD = 0.002, 2.4 / 4096
CASES = (('none', 0.0), ('delay', 0.3), ('fast_dynamics', 0.35))


def first_order(x: np.ndarray, tau_s: float, gain: float = 1.0) -> np.ndarray:
    """Exact step response of gain / (τ s + 1) to x held over each STEP_S, from rest."""
    a = np.exp(-STEP_S / tau_s)
    return lfilter([(1.0 - a) * gain], [1.0, -a], x)


def record(law: str, effect: str, value: float, duration_s: float, seed: int) -> DynamicData:
    """One 40 Hz record of two wires that follow `law`, with `effect` at `value` [s]."""
    rng = np.random.default_rng(seed)
    cmd = open_loop_duty(rng, duration_s, CMD_DT_S, 0.5)
    duty = np.repeat(cmd, int(round(CMD_DT_S / STEP_S)), axis=0)
    heat = duty
    if effect == 'delay':
        k = int(round(value / STEP_S))
        heat = np.vstack([np.zeros((k, 2)), duty[:-k]])
    elif effect == 'fast_dynamics':
        heat = np.column_stack([first_order(duty[:, i], value) for i in range(2)])
    xi = [MajorLoopHysteresis(*LOOP_C, kind=law).simulate(
        AMBIENT_C + first_order(heat[:, i], TAU_S, GAIN_K)) for i in range(2)]
    shaft = xi[1] - xi[0]
    step = int(round(1.0 / (RATE_HZ * STEP_S)))
    n = len(shaft) // step
    y = shaft[::step][:n] + rng.normal(0.0, NOISE_RAD, n)
    mean_duty = duty[:n * step].reshape(n, step, 2).mean(axis=1)
    return DynamicData(np.arange(n) / RATE_HZ, mean_duty[:, 0], mean_duty[:, 1],
                       np.round(y / ADC_LSB_RAD) * ADC_LSB_RAD, np.full(n, AMBIENT_C))


def run_case(case: tuple) -> dict:
    """Diagnose one record (law, effect, value, duration, seed); return a result row."""
    law, effect, value, duration_s, seed = case
    data = record(law, effect, value, duration_s, seed)
    t0 = time.perf_counter()
    diag = diagnose(data)
    by_name = {c['effect']: c for c in diag.candidates}
    top = [c for c in diag.candidates if c['improvement'] is not None][:2]
    return {'law': law, 'effect': effect, 'value': value, 'named': diag.missing_effect,
            'base': diag.baseline.validation['nrmse'], 'train': diag.baseline.train['nrmse'],
            'noise': noise_floor(data),
            'own': by_name.get(effect, {}).get('improvement'),
            'top': [(c['effect'], c['improvement']) for c in top],
            'seconds': time.perf_counter() - t0}


def main() -> None:
    """Command line: build the records, diagnose them side by side, print one row each."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--duration', type=float, default=480.0, help='record length [s]')
    ap.add_argument('--seed', type=int, default=300,
                    help='first record seed (law i, case j: seed + 10 i + j)')
    ap.add_argument('--jobs', type=int, default=1, help='records diagnosed in parallel')
    args = ap.parse_args()
    cases = [(law, effect, value, args.duration, args.seed + 10 * i + j)
             for i, law in enumerate(('cosine', 'ikuta'))
             for j, (effect, value) in enumerate(CASES)]
    print(f'major-loop law: {args.duration:.0f} s at {RATE_HZ:.0f} Hz, open loop, '
          f'noise {NOISE_RAD} rad, seed {args.seed}; NRMSE over the measured range, '
          'noise = its floor')
    print(f'{"law":7s} {"hidden effect":20s} {"base train/held-out":>20s} {"noise":>6s} '
          f'{"named":>14s} {"own gain":>8s}  first two ranked{"":14s} {"s":>4s}')
    hits = 0
    for _, r in imap_on_cores(run_case, cases, args.jobs):
        truth = None if r['effect'] == 'none' else r['effect']
        hits += r['named'] == truth
        own = '-' if r['own'] is None else f'{100 * r["own"]:+.0f} %'
        top = ', '.join(f'{name} {100 * gain:+.0f} %' for name, gain in r['top'])
        hidden = r['effect'] + (f' {r["value"]:g} s' if truth else '')
        print(f'{r["law"]:7s} {hidden:20s} {100 * r["train"]:8.2f} /{100 * r["base"]:6.2f} % '
              f'{100 * r["noise"]:5.2f}% {str(r["named"]):>14s} {own:>8s}  {top:30s} '
              f'{r["seconds"]:4.0f}  {"ok" if r["named"] == truth else "WRONG"}', flush=True)
    print(f'named correctly: {hits} of {len(cases)}')


if __name__ == '__main__':
    main()
