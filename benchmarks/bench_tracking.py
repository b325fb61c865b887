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
Tracking with the fitted model: pi vs pi_inverse, base model vs the model with the effect.

For each plant (an effect switched on) the benchmark
1. records an open-loop excitation (300 s at 40 Hz: `core.excitation.multilevel` on
   plant_sim's model, the simulator's own excitation on the rich simulator) and fits two
   models with the workbench
   (`workbench.engine.fit_model`, what `sma-model fit` runs): the paper's base model and
   the base model plus the plant's effect (`sma-model fit --add EFFECT`); each is written
   with the workbench's model file writer and read back with `control.load_model`;
2. tracks the paper's 0.05 Hz, ±0.5 rad sine for 3 periods with `pi` and `pi_inverse`
   on each model (`control.closed_loop.run_tracking`, 25 ms), RMS error after the first
   period.
Plants: `plant` is plant_sim's model (`control.closed_loop.CorePlant`: the core actuator
with plant_sim's potentiometer, 1 mrad noise, 12-bit ADC); `richsim` is the independent
simulator of test/support (Preisach hysteresis, RK4, its own formulation of every effect).
On the plain plant it also runs steps (±0.4 rad), a 0.2 Hz sine and 0.05 Hz squares (±0.2,
±0.4 rad, and between 0.1 and 0.5 rad on either side): rise time (10-90 %), overshoot and
RMS error, pi against pi_inverse. Drift: plant_sim's plain model fitted once, the plant's
offset or stroke then moved (runs on other days), pi_inverse with the drift estimator off
and on; and pi_inverse without the early handover (`control.handover`).

Run: python benchmarks/bench_tracking.py [--source plant richsim] [--cases plain delay ...]
     [--models DIR] (fitted models are cached in DIR; delete it to refit)
     [--detune 1 0.5 ...] (each case again with the PI gains scaled by these factors)
     [--param KEY=VALUE ...] (another rig of the rich simulator: test/support/richsim.py
     DEFAULTS keys, e.g. --param wire_length_m=0.3)
     [--excitation rig] (the rich simulator's models fitted on the package's identification
     design in the rig's time constant, `sma-model excite`, instead of its own excitation)
"""
import argparse
from pathlib import Path
import sys
import time
import warnings

import numpy as np

from sma_actuator.control import ControllerCore, ControllerSettings, law, load_model
from sma_actuator.control.closed_loop import CorePlant, run_tracking
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.core.excitation import multilevel, rig_excitation
from sma_actuator.core.identification import DynamicData
from sma_actuator.core.model_file import write_model
from sma_actuator.profiles import Profile
from sma_actuator.workbench.engine import fit_model

DT = 0.025
# the rich simulator's rig parameters for this run (--param; {}: its defaults)
RICH_RIG = {}
# the rich simulator's identification record (--excitation): 'own' its own excitation, 'rig'
# the package's design in the rig's time constant (`core.excitation.rig_excitation`)
RICH_EXCITATION = 'own'
SINE = Profile('sine', 0.5, period_s=20.0, delay_s=1.0)
# plant_sim parameters of each case (level 1-2 of test/support/plant_records.py)
PLANT_CASES = {
    'plain': ({}, None),
    'delay': ({'delay_s': 0.3}, 'delay'),
    'asymmetric_wires': ({'gain_ratio_b': 0.6, 'stroke_ratio_b': 1.5}, 'asymmetric_wires'),
    'sensor_nonlinearity': ({'sensor_c2_rad': 0.15, 'sensor_c3_rad': -0.1,
                             'sensor_c4_rad': 0.05}, 'sensor_nonlinearity'),
}
# rich simulator (effect, magnitude) of each case
RICH_CASES = {
    'plain': (('none', 0.0), None),
    'delay': (('delay', 1.0), 'delay'),
    'asymmetric_wires': (('asymmetric_wires', 2.0), 'asymmetric_wires'),
    'sensor_nonlinearity': (('sensor_nonlinearity', 1.5), 'sensor_nonlinearity'),
}


# plant_sim's plain plant with its offset / stroke moved away from the fitted model's
DRIFT_CASES = {
    'matched': {},
    'offset +0.08 rad': {'offset_rad': 0.08},
    'stroke -20 %': {'stroke_rad': 0.8},
    'offset -0.08, stroke +20 %': {'offset_rad': -0.08, 'stroke_rad': 1.2},
}


def make_plant(source, case, seed, **core_plant):
    """
    Return a fresh plant of `source` for `case` (a dict: plant_sim parameter changes).

    core_plant: further `CorePlant` arguments (plant_sim's model only).
    """
    if source == 'plant':
        changes = case if isinstance(case, dict) else PLANT_CASES[case][0]
        return CorePlant(ActuatorParams(**changes), DT, seed=seed, **core_plant)
    from support.richsim_loop import RichPlant
    effect, magnitude = RICH_CASES[case][0]
    return RichPlant(effect, magnitude, seed=seed, params=RICH_RIG)


def excitation_record(source, case, seconds, seed):
    """
    Return the DynamicData of an open-loop excitation record of the plant.

    plant_sim's model: `core.excitation.multilevel` (what scripts/fit_controller_model.py
    records); the rich simulator: its own open-loop excitation (test/support/richsim.py),
    or with RICH_EXCITATION 'rig' what `sma-model excite` writes for its time constant.
    """
    if source == 'richsim':
        from support.richsim import DEFAULTS, simulate, simulate_profile
        effect, magnitude = RICH_CASES[case][0]
        if RICH_EXCITATION == 'rig':
            rig = dict(DEFAULTS, **RICH_RIG)
            duty = rig_excitation(seconds, DT, rig['cooling_tau_s'], rig['duty_max'], seed=seed)
            d = simulate_profile(*duty, effect=effect, magnitude=magnitude, rate_hz=1.0 / DT,
                                 noise_rad=0.002, seed=seed, params=RICH_RIG)
        else:
            d = simulate(effect, magnitude, 'open', duration_s=seconds, rate_hz=1.0 / DT,
                         seed=seed, params=RICH_RIG)
        return DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'],
                           d['ambient_temperature'])
    duty_a, duty_b = multilevel(seconds, DT, seed=seed)
    # no interlock, as `in_process.run_excitation`: the record's duties must be the applied
    # ones, and `multilevel` passes from one wire straight to the other
    plant = make_plant(source, case, seed + 1000, dead_time_s=0.0)
    pos = [plant.measure()]
    amb = [plant.ambient_c()]
    for a, b in zip(duty_a[:-1], duty_b[:-1]):
        pos.append(plant.step(a, b))
        amb.append(plant.ambient_c())
    return DynamicData(np.arange(len(duty_a)) * DT, duty_a, duty_b, np.array(pos),
                       np.array(amb))


def fitted_model(models, source, case, effects, seconds, seed):
    """Fit (or read the cached) model file; return (model, validation NRMSE, path)."""
    rig = ''.join(f'_{k}={v:g}' for k, v in sorted(RICH_RIG.items()) if source == 'richsim')
    if source == 'richsim' and RICH_EXCITATION != 'own':
        rig += f'_{RICH_EXCITATION}'
    path = models / f'{source}{rig}_{case}_{"+".join(effects) or "base"}.yaml'
    if not path.exists():
        fit = fit_model(excitation_record(source, case, seconds, seed), tuple(effects))
        write_model(path, fit.to_dict(), force=True)
    with warnings.catch_warnings():
        warnings.simplefilter('ignore')
        spec_nrmse = __import__('yaml').safe_load(path.read_text())['scores']['validation']
    return load_model(path), spec_nrmse['nrmse'], path


def sine_rms(model, mode, source, case, seed=7, profile=SINE, periods=3, **settings):
    """RMS error [rad] after the first period of the sine; settings: ControllerSettings."""
    ctrl = ControllerCore(model, ControllerSettings(mode=mode, **settings))
    run = run_tracking(ctrl, make_plant(source, case, seed), profile,
                       profile.delay_s + periods * profile.period_s, DT)
    return run.summary(profile.delay_s + profile.period_s)['rms_error']


def step_metrics(model, mode, source, amplitude):
    """(rise time 10-90 % [s], overshoot [% of the step], RMS [rad]) of a step from 0."""
    step = Profile('step', amplitude, delay_s=2.0)
    run = run_tracking(ControllerCore(model, ControllerSettings(mode=mode)),
                       make_plant(source, 'plain', 7), step, 12.0, DT)
    t, y = run.time_s - step.delay_s, run.position * np.sign(amplitude)
    a = abs(amplitude)
    after = t >= 0
    y0 = float(y[np.searchsorted(t, 0.0) - 1])
    t10 = t[after][np.argmax(y[after] >= y0 + 0.1 * (a - y0))]
    t90 = t[after][np.argmax(y[after] >= y0 + 0.9 * (a - y0))]
    reached = np.any(y[after] >= y0 + 0.9 * (a - y0))
    overshoot = 100.0 * max(0.0, float(np.max(y[after])) - a) / a
    rms = run.summary(step.delay_s)['rms_error']
    return (float(t90 - t10) if reached else float('nan')), overshoot, rms


def drift_table(models, seconds, seed):
    """Print pi_inverse on plant_sim with its offset / stroke moved: drift estimator off / on."""
    model, _, _ = fitted_model(models, 'plant', 'plain', [], seconds, seed)
    print('\nplant_sim, model fitted on the plain plant, plant offset / stroke then moved: '
          'pi_inverse sine RMS [rad], drift estimator off / on (drift_time_s 30 s)')
    print(f'{"plant":28s} {"pi":>8s} {"drift off":>10s} {"drift on":>10s} {"on / off":>9s}')
    for label, changes in DRIFT_CASES.items():
        pi = sine_rms(model, 'pi', 'plant', changes)
        off, on = (sine_rms(model, 'pi_inverse', 'plant', changes, drift_correction=d)
                   for d in (False, True))
        print(f'{label:28s} {pi:8.4f} {off:10.4f} {on:10.4f} {on / off:9.3f}', flush=True)
    without = sine_rms(model, 'pi_inverse', 'plant', 'plain', preheat=False)
    print(f'pi_inverse without the early handover (preheat off), plain plant: {without:.4f} rad')


def detune_table(models, sources, cases, scales, seconds, seed):
    """Print the sine RMS with the PI gains scaled down (a gentler PI is not the cure)."""
    print('\nthe PI gains (kp, ki of the model) scaled by ' + ', '.join(map(str, scales))
          + ': sine RMS [rad]')
    for source in sources:
        for case in cases:
            effect = (PLANT_CASES if source == 'plant' else RICH_CASES)[case][1]
            for effects in ([[]] if effect is None else [[], [effect]]):
                model, _, _ = fitted_model(models, source, case, effects, seconds, seed)
                for mode in ('pi', 'pi_inverse'):
                    kp, ki = ControllerCore(model, ControllerSettings(mode=mode)).gains()
                    rms = [sine_rms(model, mode, source, case, kp=f * kp, ki=f * ki)
                           for f in scales]
                    label = f'base+{effects[0]}' if effects else 'base'
                    print(f'{source:8s} {case:12s} {label:16s} {mode:10s} kp {kp:5.2f} '
                          f'ki {ki:5.2f}: ' + ' '.join(f'{r:7.4f}' for r in rms), flush=True)


def figure(path, models, seconds, seed):
    """Plot pi_inverse on plant_sim's model with a 0.3 s delay: base vs delay model."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot as plt
    fig, ax = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    runs = {}
    for effects, label in (([], 'base model'), (['delay'], 'base model + delay')):
        model, nrmse, _ = fitted_model(models, 'plant', 'delay', effects, seconds, seed)
        ctrl = ControllerCore(model, ControllerSettings(mode='pi_inverse'))
        run = run_tracking(ctrl, make_plant('plant', 'delay', 7), SINE, 61.0, DT)
        rms = run.summary(21.0)['rms_error']
        runs[label] = run
        ax[0].plot(run.time_s, run.position, label=f'{label} (fit NRMSE {100 * nrmse:.2f} %): '
                   f'RMS {rms:.3f} rad')
        ax[1].plot(run.time_s, run.setpoint - run.position, label=label)
    ax[0].plot(run.time_s, run.setpoint, 'k--', lw=1, label='setpoint')
    ax[0].set_ylabel('measured angle [rad]')
    ax[0].set_title('pi_inverse on plant_sim with a 0.3 s delay (models fitted by sma-model fit)')
    ax[0].legend(fontsize=8, loc='lower left')
    ax[1].set_ylabel('error [rad]')
    ax[1].set_xlabel('time [s]')
    ax[1].legend(fontsize=8)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    print(f'figure: {path}')


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    ap.add_argument('--source', nargs='*', default=['plant', 'richsim'],
                    choices=['plant', 'richsim'])
    ap.add_argument('--cases', nargs='*', default=list(PLANT_CASES), choices=list(PLANT_CASES))
    ap.add_argument('--models', default='runs/bench_tracking_models',
                    help='directory of the fitted model files (cache)')
    ap.add_argument('--excitation-s', type=float, default=300.0)
    ap.add_argument('--seed', type=int, default=1, help='excitation seed')
    ap.add_argument('--no-steps', action='store_true', help='skip steps and the 0.2 Hz sine')
    ap.add_argument('--no-drift', action='store_true', help='skip the drift table')
    ap.add_argument('--figure', default='', metavar='PNG',
                    help='also plot pi_inverse on the delayed plant, base vs delay model')
    ap.add_argument('--detune', nargs='*', type=float, default=[], metavar='SCALE',
                    help='also run each case with the PI gains scaled by these factors')
    ap.add_argument('--param', action='append', default=[], metavar='KEY=VALUE',
                    help='a rich-simulator rig parameter (test/support/richsim.py DEFAULTS)')
    ap.add_argument('--excitation', choices=['own', 'rig'], default='own',
                    help="the rich simulator's identification record: its own excitation, or "
                    "the package's design in the rig's time constant (sma-model excite)")
    ap.add_argument('--antagonist-lag-share', type=float, default=law.ANTAGONIST_LAG_SHARE,
                    metavar='SHARE', help='control.law.ANTAGONIST_LAG_SHARE for this run '
                    '(inf: the one-sided PI never lets the antagonist pull)')
    ns = ap.parse_args()
    if not ns.antagonist_lag_share > 0:
        ap.error('--antagonist-lag-share must be positive (inf to switch the release off)')
    law.ANTAGONIST_LAG_SHARE = ns.antagonist_lag_share
    global RICH_EXCITATION
    RICH_EXCITATION = ns.excitation
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
    from support.richsim import rig_from_command_line
    RICH_RIG.update(rig_from_command_line(ap, ns.param, 'richsim' in ns.source))
    if RICH_RIG.get('cmd_dt_s', DT) != DT:
        # RichPlant.step holds a command for one plant tick: another tick than the control
        # period would run the plant on another clock than the controller
        ap.error(f'--param cmd_dt_s must be the control period, {DT:g} s, here')
    models = Path(ns.models)
    models.mkdir(parents=True, exist_ok=True)
    print('0.05 Hz ±0.5 rad sine, 3 periods, RMS error after the first [rad]; models fitted on '
          f'{ns.excitation_s:g} s of open-loop excitation (validation NRMSE in brackets)')
    if RICH_RIG:
        print('rich simulator rig: ' + ', '.join(f'{k} = {v:g}' for k, v in RICH_RIG.items()))
    print(f'{"plant":8s} {"case":20s} {"model":24s} {"pi":>8s} {"pi_inverse":>11s} '
          f'{"inv/pi":>7s} {"effect cuts pi_inverse":>23s}')
    for source in ns.source:
        for case in ns.cases:
            effect = (PLANT_CASES if source == 'plant' else RICH_CASES)[case][1]
            rows = []
            for effects in ([[]] if effect is None else [[], [effect]]):
                t0 = time.monotonic()
                model, nrmse, _ = fitted_model(models, source, case, effects, ns.excitation_s,
                                               ns.seed)
                rms = {m: sine_rms(model, m, source, case) for m in ('pi', 'pi_inverse')}
                rows.append((effects, nrmse, rms, time.monotonic() - t0))
            for i, (effects, nrmse, rms, _) in enumerate(rows):
                cut = ''
                if i == 1:
                    gain = 1.0 - rms['pi_inverse'] / rows[0][2]['pi_inverse']
                    cut = f'{100 * gain:+.0f} % ({"met" if gain >= 0.2 else "NOT met"})'
                label = f'base+{effects[0]}' if effects else 'base'
                label = f'{label} [{100 * nrmse:.2f} %]'
                ratio = rms['pi_inverse'] / rms['pi']
                print(f'{source:8s} {case:20s} {label:24s} {rms["pi"]:8.4f} '
                      f'{rms["pi_inverse"]:11.4f} {ratio:7.3f} {cut:>23s}', flush=True)
    if ns.detune:
        detune_table(models, ns.source, ns.cases, ns.detune, ns.excitation_s, ns.seed)
    if ns.figure:
        figure(ns.figure, models, ns.excitation_s, ns.seed)
    if 'plant' in ns.source and not ns.no_drift:
        drift_table(models, ns.excitation_s, ns.seed)
    if ns.no_steps:
        return
    print('\nplain plant, base model: steps from 0 (rise 10-90 % [s], overshoot [%], RMS [rad]), '
          'a 0.2 Hz ±0.5 rad sine and 0.05 Hz squares (RMS after the first period [rad])')
    print(f'{"plant":8s} {"reference":16s} {"pi":>26s} {"pi_inverse":>26s}')
    for source in ns.source:
        model, _, _ = fitted_model(models, source, 'plain', [], ns.excitation_s, ns.seed)
        for amplitude in (0.4, -0.4):
            cells = []
            for mode in ('pi', 'pi_inverse'):
                rise, over, rms = step_metrics(model, mode, source, amplitude)
                cells.append(f'{rise:5.2f} s {over:5.1f} % {rms:6.4f}')
            print(f'{source:8s} {f"step {amplitude:+.1f} rad":16s} {cells[0]:>26s} '
                  f'{cells[1]:>26s}')
        fast = Profile('sine', 0.5, period_s=5.0, delay_s=1.0)
        cells = [f'{sine_rms(model, m, source, "plain", profile=fast, periods=4):.4f}'
                 for m in ('pi', 'pi_inverse')]
        print(f'{source:8s} {"sine 0.2 Hz":16s} {cells[0]:>26s} {cells[1]:>26s}', flush=True)
        # about 0, and between two levels on one side (0.1 and 0.5 rad, -0.1 and -0.5 rad)
        for low, high in ((-0.2, 0.2), (-0.4, 0.4), (0.1, 0.5), (-0.5, -0.1)):
            square = Profile('square', (high - low) / 2, offset=(high + low) / 2,
                             period_s=20.0, delay_s=1.0)
            cells = [f'{sine_rms(model, m, source, "plain", profile=square):.4f}'
                     for m in ('pi', 'pi_inverse')]
            print(f'{source:8s} {f"square {low:+.1f}/{high:+.1f} rad":20s} {cells[0]:>22s} '
                  f'{cells[1]:>26s}', flush=True)


if __name__ == '__main__':
    main()
