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
Tracking on wires that heat slowly: the free preheat window in the wire's own heating time.

    python benchmarks/bench_slow_wires.py [--scales 0.5 1 2 3 4] [--periods 20 10 5]
        [--fitted] [--models DIR]

plant_sim's model (`control.closed_loop.CorePlant`) with its heat capacity scaled by each
of --scales (the thermal time constant and the heating time to As scale with it) tracks
±0.5 rad sines of each period [s], 3 periods, RMS error after the first [rad]: pi, and
pi_inverse twice, with the free preheat window held at `handover.FREE_LEAD_S` (3 s, as
before the window was counted in heating times) and as shipped (`Preheat.free_lead_s`:
`handover.FREE_LEAD_HEATS` heating times of the incoming wire, at least 3 s). The model is
the plant's own; with --fitted also the base model `sma-model fit` identifies from 300 s
of the plant's open-loop excitation (as bench_tracking.py; cached in --models).
"""
import argparse
from pathlib import Path

from bench_tracking import excitation_record
from sma_actuator.control import ControllerCore, ControllerSettings, handover, load_model
from sma_actuator.control.closed_loop import CorePlant, run_tracking
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.core.model_file import write_model
from sma_actuator.profiles import Profile
from sma_actuator.workbench.engine import fit_model

DT = 0.025


def slow_plant(scale):
    """Return plant_sim's parameter changes with the heat capacity scaled by `scale`."""
    return {'heat_capacity_j_per_k': scale * ActuatorParams().heat_capacity_j_per_k}


def fitted(models, scale):
    """Return the base model fitted on the plant's excitation (cached in `models`)."""
    path = Path(models) / f'plant_heat_capacity_x{scale:g}_base.yaml'
    if not path.exists():
        fit = fit_model(excitation_record('plant', slow_plant(scale), 300.0, 1))
        write_model(path, fit.to_dict(), force=True)
    return load_model(path)


def sine_rms(model, plant, period_s, mode, window_s=None):
    """RMS error [rad] after the first period; window_s: free preheat window held [s]."""
    ctrl = ControllerCore(model, ControllerSettings(mode=mode))
    if window_s is not None:
        ctrl.handover.free_lead_s = (window_s, window_s)
    sine = Profile('sine', 0.5, period_s=period_s, delay_s=1.0)
    run = run_tracking(ctrl, CorePlant(plant, DT, seed=7), sine, 1.0 + 3 * period_s, DT)
    return run.summary(1.0 + period_s)['rms_error']


def main():
    """Print pi and pi_inverse (3 s window, shipped window) per heat capacity and period."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--scales', nargs='*', type=float, default=[0.5, 1.0, 2.0, 3.0, 4.0])
    ap.add_argument('--periods', nargs='*', type=float, default=[20.0, 10.0, 5.0])
    ap.add_argument('--fitted', action='store_true')
    ap.add_argument('--models', default='runs/bench_slow_wires_models')
    args = ap.parse_args()
    Path(args.models).mkdir(parents=True, exist_ok=True)
    print('plant_sim, heat capacity scaled: ±0.5 rad sine, RMS error after the first period '
          '[rad]; pi_inverse with the window held at 3 s and as shipped')
    print(f'{"C x":>4s} {"heat to As":>10s} {"window":>7s} {"model":>7s} {"period":>7s} '
          f'{"pi":>7s} {"inv 3 s":>8s} {"inv":>7s} {"inv/pi":>7s}')
    for scale in args.scales:
        plant = ActuatorParams(**slow_plant(scale))
        models = [('exact', plant)] + ([('fitted', fitted(args.models, scale))]
                                       if args.fitted else [])
        for name, model in models:
            pre = ControllerCore(model, ControllerSettings(mode='pi_inverse')).handover
            heat_s = pre.time_needed_s(0, model.ambient_c, model.ambient_c)
            for period in args.periods:
                pi = sine_rms(model, plant, period, 'pi')
                held = sine_rms(model, plant, period, 'pi_inverse', handover.FREE_LEAD_S)
                inv = sine_rms(model, plant, period, 'pi_inverse')
                print(f'{scale:4g} {heat_s:8.2f} s {pre.free_lead_s[0]:5.2f} s {name:>7s} '
                      f'{period:5g} s {pi:7.4f} {held:8.4f} {inv:7.4f} {inv / pi:7.3f}',
                      flush=True)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
