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
Whether `sensor_nonlinearity` removes a residual that is the same on both branches.

Its signature says a sensor error is a static function of the position, the same rising
and falling. For rich-simulator records of the two-effect table (`bench_two_effects.py`,
the same pairs and seeds), the named or true effects other than the sensor are fitted from
scratch, then the sensor polynomial is added (a warm refit). The residual (model −
measured) of each fit is binned by measured position, separately while the smoothed
position rises and falls. The mean of the two branch curves is the static part, half
their difference the branch part; each is printed as an RMS over the bins [mrad], with
the held-out NRMSE before and after the polynomial and the share of the static part it
removes.

    python benchmarks/bench_sensor_signature.py [--jobs 2] [--rate 40] [--duration 480]
"""
import argparse
from pathlib import Path
import sys
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` and the record workers run
keep_freed_memory()
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_two_effects import record, RICH_PAIRS  # noqa: E402, I100
import numpy as np  # noqa: E402
from sma_actuator.core.identification import DynamicData  # noqa: E402
from sma_actuator.workbench.compare import direction_masks, smooth, SMOOTH_S  # noqa: E402
from sma_actuator.workbench.engine import fit_model  # noqa: E402
from support.parallel import imap_on_cores  # noqa: E402

# (index in RICH_PAIRS, the effects fitted before the sensor): the sensor is hidden in the
# records of 5 and 8; in 4 and 9 diagnose names it after both true effects
CASES = [(3, ('ambient_drift', 'phase_resistance')),
         (4, ('asymmetric_wires', 'current_limit')),
         (5, ('fatigue_drift',)),
         (8, ('ambient_drift',)),
         (9, ('asymmetric_wires', 'fast_dynamics'))]
BINS = 16
MIN_SAMPLES = 20   # per bin and branch


def branch_parts(data: DynamicData, residual: np.ndarray) -> tuple:
    """
    Return (static part, branch part) of `residual` [rad], each an RMS over position bins.

    The static part is taken about its mean: a constant offset is no sensor error.
    """
    y = data.position
    moving = direction_masks(smooth(y, round(SMOOTH_S / data.dt)), np.ptp(y), data.dt)
    edges = np.quantile(y, np.linspace(0.0, 1.0, BINS + 1))
    cell = np.clip(np.searchsorted(edges, y) - 1, 0, BINS - 1)
    curves = []
    for branch in (moving['rising'], moving['falling']):
        curves.append([residual[(cell == b) & branch].mean()
                       if np.sum((cell == b) & branch) >= MIN_SAMPLES else np.nan
                       for b in range(BINS)])
    rising, falling = map(np.asarray, curves)
    both = np.isfinite(rising) & np.isfinite(falling)
    static = 0.5 * (rising + falling)[both]
    branch = 0.5 * (rising - falling)[both]
    return float(np.std(static)), float(np.sqrt(np.mean(branch ** 2)))


def run_case(case: tuple) -> str:
    """Fit one record without and with the sensor polynomial; return its result line."""
    (index, effects), args = case
    started = time.perf_counter()
    e1, l1, e2, l2 = RICH_PAIRS[index]
    data = record(args, e1, l1, e2, l2, 700 + index)
    without = fit_model(data, list(effects))
    with_sensor = fit_model(data, list(effects) + ['sensor_nonlinearity'], base_fit=without)
    s0, b0 = branch_parts(data, without.prediction - data.position)
    s1, b1 = branch_parts(data, with_sensor.prediction - data.position)
    return (f'{e1 + " + " + e2:40s} {" + ".join(effects):34s} '
            f'{100 * without.validation["nrmse"]:5.2f} > '
            f'{100 * with_sensor.validation["nrmse"]:5.2f} %   '
            f'{1e3 * s0:5.2f} > {1e3 * s1:5.2f}   {1e3 * b0:5.2f} > {1e3 * b1:5.2f}   '
            f'{100 * (1.0 - s1 / s0):4.0f} %  {time.perf_counter() - started:4.0f}')


def main():
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--jobs', type=int, default=2, help='records in parallel')
    ap.add_argument('--rate', type=float, default=40.0, help='sample rate [Hz]')
    ap.add_argument('--duration', type=float, default=480.0, help='record length [s]')
    args = ap.parse_args()
    # the two-effect table's open-loop records of the first rig
    args.source, args.excitation, args.params = 'richsim', 'open', None
    print(f'richsim: {args.duration:.0f} s at {args.rate:g} Hz, open loop, noise 0.002 rad')
    print(f'{"hidden effects":40s} {"fitted before the sensor":34s} {"held-out NRMSE":17s} '
          f'{"static [mrad]":15s} {"branch [mrad]":15s} static removed  s')
    for _, line in imap_on_cores(run_case, [(c, args) for c in CASES], args.jobs):
        print(line, flush=True)


if __name__ == '__main__':
    main()
