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
How near clean simulated records come to the sensor-glitch rule (`workbench.glitches`).

For records without glitches, from the rich simulator (every effect at the ends of its
range; open loop with two wires and with one, closed loop, and the package's rig
excitation) and from the package's plant (every effect at its three levels), at 10, 25,
40, 100, 200 and 1000 Hz: the largest excursion of 1 to `max_glitch_samples` samples (3 up
to 100 Hz, 30 ms above) that comes back, over the clearance D a glitch must exceed (1.0
would be read as a glitch), and the records where any sample is read as one.

With --real, the measured spring-biased wire records (../shared/data/real) instead:
`sma-model fit step_a ramp_a square_a` (each left out in turn) as they are, with eight
single samples of step_a 12 mm off (a wiper lifting off its track), and the same with
--keep-glitches: each record's held-out NRMSE and RMSE [mm].

    python benchmarks/bench_glitch_margin.py [--duration 240] [--real]
"""
import argparse
import contextlib
import io
import json
from pathlib import Path
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))

from conftest import real_data_path  # noqa: E402, I100
from sma_actuator.core.excitation import rig_excitation  # noqa: E402
from sma_actuator.workbench import cli  # noqa: E402
from sma_actuator.workbench.glitches import (  # noqa: E402
    excursions, glitch_mask, glitch_threshold, max_glitch_samples)
from support import plant_records  # noqa: E402
from support.csv_edit import edit_positions, shifted  # noqa: E402
from support.richsim import DEFAULTS, EFFECTS, simulate, simulate_profile  # noqa: E402

RATES_HZ = (10.0, 25.0, 40.0, 100.0, 200.0, 1000.0)
WIRE = Path(real_data_path()).parent / 'spring_biased_wire'
GLITCH_ROWS = (516, 965, 1100, 2089, 3682, 3868, 4058, 4662)   # data rows of step_a
GLITCH_MM = 12.0


def nearness(position, max_samples):
    """Return the largest excursion that comes back, over the clearance D of the rule."""
    y = np.asarray(position, float)
    clearance = glitch_threshold(y, max_samples)
    worst = max(float(np.max(excursions(y, run, clearance), initial=-np.inf))
                for run in range(1, max_samples + 1))
    return worst / clearance


def richsim_records(duration_s, rate_hz):
    """Yield (label, position) of the rich simulator's records at `rate_hz`."""
    for effect, spec in EFFECTS.items():
        for magnitude in sorted(set(spec['magnitude_range'])):
            for excitation, layout in (('open', 'antagonistic'), ('open', 'single'),
                                       ('closed', 'antagonistic'), ('rig', 'antagonistic')):
                label = f'richsim {effect} {magnitude:g} {excitation} {layout}'
                if excitation == 'rig':
                    if effect == 'saturation':   # an excitation of its own
                        continue
                    duty = rig_excitation(duration_s, DEFAULTS['cmd_dt_s'],
                                          DEFAULTS['cooling_tau_s'], DEFAULTS['duty_max'],
                                          layout, 1)
                    d = simulate_profile(*duty, effect=effect, magnitude=magnitude,
                                         rate_hz=rate_hz, noise_rad=0.002, seed=1)
                else:
                    try:
                        d = simulate(effect, magnitude=magnitude, excitation=excitation,
                                     duration_s=duration_s, rate_hz=rate_hz, seed=1,
                                     layout=layout)
                    except ValueError:   # an effect that needs two wires
                        continue
                yield label, d['position']


def plant_record_set(duration_s, rate_hz):
    """Yield (label, position) of the package's plant with each effect at each level."""
    for effect in plant_records.EFFECTS:
        for level in (0, 1, 2):
            d = plant_records.simulate(effect, level, duration_s=duration_s, rate_hz=rate_hz,
                                       seed=2)
            yield f'plant {effect} L{level}', d['position']


def leave_one_out(records, *options):
    """Return [(name, NRMSE %, RMSE mm)] of `sma-model fit RECORDS` for each record."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = cli.main(['fit', *map(str, records), *options, '--json'])
    if code:
        sys.exit(f'fit failed ({code})')
    return [(Path(r['data']).stem, 100 * r['scores']['all']['nrmse'],
             r['scores']['all']['rmse']) for r in json.loads(out.getvalue())['records']]


def real_records():
    """Print the leave-one-out scores of the measured records, clean and glitched."""
    clean = [WIRE / f'{name}.csv' for name in ('step_a', 'ramp_a', 'square_a')]
    with tempfile.TemporaryDirectory() as tmp:
        added = dict.fromkeys(GLITCH_ROWS, shifted(GLITCH_MM))
        glitched = [edit_positions(clean[0], Path(tmp) / 'step_a.csv', added)] + clean[1:]
        runs = (('as measured', clean, ()), ('8 glitches in step_a', glitched, ()),
                ('the same, --keep-glitches', glitched, ('--keep-glitches',)))
        for label, records, options in runs:
            t0 = time.perf_counter()
            scores = '   '.join(f'{name} {nrmse:.2f} % ({rmse:.3f} mm)' for name, nrmse, rmse
                                in leave_one_out(records, *options))
            print(f'{label:27s} {scores}   {time.perf_counter() - t0:.0f} s', flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--duration', type=float, default=240.0, help='record length [s]')
    ap.add_argument('--real', action='store_true', help='the measured wire records instead')
    args = ap.parse_args()
    if args.real:
        real_records()
        return
    t0 = time.perf_counter()
    print('source   rate [Hz]  run [samples]  records  largest excursion / D  (record)        '
          'read as glitches')
    for name, records in (('richsim', richsim_records), ('plant', plant_record_set)):
        for rate_hz in RATES_HZ:
            longest = max_glitch_samples(1.0 / rate_hz)
            rows = [(nearness(y, longest), label, int(glitch_mask(y, longest)[0].sum()))
                    for label, y in records(args.duration, rate_hz)]
            worst = max(rows)
            fired = [f'{label} ({n})' for _, label, n in rows if n]
            print(f'{name:8s} {rate_hz:9g}  {longest:13d}  {len(rows):7d}  {worst[0]:21.3f}  '
                  f'({worst[1]})  {", ".join(fired) or "none"}', flush=True)
    print(f'{time.perf_counter() - t0:.0f} s')


if __name__ == '__main__':
    main()
