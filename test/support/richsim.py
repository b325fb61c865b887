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
Rich, independent simulator of the antagonistic SMA wire actuator (test-data generator).

It makes recordings with one hidden physical effect at a time for the model-workbench
tests and deliberately shares no code or formulation with sma_actuator: Preisach hysteresis
(Gaussian relay density, Everett function) instead of Prandtl-Ishlinskii, RK4 on a <= 1 ms
grid, its own PI controller, and its own formulation of each effect (docs/richsim.md).

    from support.richsim import simulate, write_csv      # with test/ on sys.path
    data = simulate('delay', magnitude=1.0, excitation='closed', duration_s=600, rate_hz=40)
"""
import math

import numpy as np

from . import richsim_excitation as exc
from .richsim_kernel import (
    N_WIRE_FIELDS,
    Plant,
    run,
    W_AREA,
    W_C,
    W_FATIGUE,
    W_HA,
    W_LEN,
    W_R,
    W_STROKE,
)
from .richsim_preisach import everett_table, new_state

EFFECTS = {
    'none': {'description': 'null case: no hidden effect (magnitude ignored)',
             'magnitude_range': (0.0, 0.0)},
    'saturation': {'description': 'excitation drives full transformation hard: fraction '
                   'min(1, 0.5 M) of segments are long max-duty pulses / out-of-reach setpoints',
                   'magnitude_range': (0.5, 2.0)},
    'fast_dynamics': {'description': 'second thermal node: Joule heat reaches the transforming '
                      'wire through a lag tau = 0.3 M s', 'magnitude_range': (0.33, 2.0)},
    'delay': {'description': 'transport delay 0.2 M s in the command path (duty -> amplifier)',
              'magnitude_range': (0.25, 2.5)},
    'convection': {'description': 'natural convection Q ~ dT^(1 + 0.25 M) (normalised at 50 K) '
                   'plus radiation with emissivity 0.3 M', 'magnitude_range': (0.4, 2.0)},
    'ambient_drift': {'description': 'ambient drifts 6 M K ramp + 4 M K sine over the run '
                      '(measured in ambient_temperature)', 'magnitude_range': (0.5, 1.5)},
    'phase_resistance': {'description': 'R(xi) = R_M (1 + rho xi)/(1 + rho), martensite '
                         'rho = 18 M % above austenite, through the PWM/current-limit law',
                         'magnitude_range': (0.5, 1.4)},
    'stress_coupling': {'description': "loop tension shifts both wires' transformation "
                        'temperatures up by 10 M K per full stroke of contraction',
                        'magnitude_range': (0.3, 2.0)},
    'asymmetric_wires': {'description': 'wire b: 4 M % longer, 12 M % more recoverable '
                         'strain, 8 M % less convective cooling (e.g. sleeved)',
                         'magnitude_range': (0.5, 3.0)},
    'sensor_nonlinearity': {'description': 'potentiometer error 0.05 M FS (0.8 sin(pi x) + '
                            '0.4 x^2), x = angle/1.2 rad, peak about 4.5 M % of full scale',
                            'magnitude_range': (0.45, 2.2)},
    'fatigue_drift': {'description': 'functional fatigue vs accumulated cycles N: stroke loss '
                      '20 M % and plastic elongation 0.3 M % (wire a; 0.35x on b) times '
                      '1 - exp(-N/15)', 'magnitude_range': (0.3, 2.0)},
    'current_limit': {'description': 'soft average-current limit: effective duty saturates '
                      'above the knee duty 0.45 / M', 'magnitude_range': (0.5, 1.5)},
}
EXCITATIONS = ('open', 'closed')
LAYOUTS = ('antagonistic', 'single')
MAX_MAGNITUDE = 3.0

DEFAULTS = {
    'wire_diameter_m': 150e-6, 'wire_length_m': 0.25, 'resistance_ohm_per_m': 55.0,
    'density_kg_m3': 6450.0, 'specific_heat_j_kg_k': 500.0, 'cooling_tau_s': 1.5,
    'strain_max': 0.04, 'ambient_c': 22.0, 'supply_v': 5.0, 'i_max_a': 0.35,
    'pulley_r_m': 0.005, 'phi0_rad': 0.02, 'adc_half_range_rad': 1.2, 'adc_bits': 12,
    'ambient_noise_c': 0.05, 'ambient_lsb_c': 0.0625, 'cmd_dt_s': 0.025, 'fine_dt_s': 1e-3,
    'duty_max': 0.5, 'kp': 0.3, 'ki': 0.1, 'd0': 0.22, 'u_knee': 0.1,
    'hyst_centre_c': 60.0, 'hyst_width_k': 26.0, 'hyst_centre_sd_k': 1.5,
    'hyst_width_sd_k': 3.0,
    'stress_self_weight': 1.0,   # stress_coupling: weight of a wire's own contraction (1: equal
                                 # tension on a frictionless pulley, 0: antagonist load only)
}
_SIGNED = ('ambient_c', 'phi0_rad', 'hyst_centre_c')                # may be negative
_ZERO_OK = ('d0', 'ki', 'ambient_noise_c', 'stress_self_weight')   # may be 0; others > 0
CSV_COLUMNS = ('time', 'duty_a', 'duty_b', 'position', 'ambient_temperature', 'setpoint')
_CSV_FMT = {'time': '%.6f', 'duty_a': '%.5f', 'duty_b': '%.5f', 'position': '%.6f',
            'ambient_temperature': '%.4f', 'setpoint': '%.6f'}


def _check_number(name, value, lo=None, hi=None, lo_open=False):
    """Return float(value) or raise ValueError naming the parameter."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be a number, got {value!r}') from None
    if not math.isfinite(v) or (lo is not None and (v < lo or (lo_open and v == lo))) \
            or (hi is not None and v > hi):
        raise ValueError(f'{name}={value!r} out of range [{lo}, {hi}]')
    return v


def _params(params):
    """DEFAULTS updated by `params`; unknown keys and out-of-range values are errors."""
    pp = dict(DEFAULTS)
    for key, val in (params or {}).items():
        if key not in DEFAULTS:
            raise ValueError(f'params: unknown key {key!r} (known: {sorted(DEFAULTS)})')
        if key in _SIGNED:
            pp[key] = _check_number(f'params[{key!r}]', val, -100.0, 200.0)
        else:
            pp[key] = _check_number(f'params[{key!r}]', val, 0.0, lo_open=key not in _ZERO_OK)
    if pp['duty_max'] > 1.0:
        raise ValueError(f"params['duty_max']={pp['duty_max']} must be <= 1")
    return pp


def parse_rig(pairs):
    """
    Return the rig parameters {key: value} of 'KEY=VALUE' strings, checked as `simulate` does.

    For command lines (`--param wire_length_m=0.3`); a malformed pair, an unknown key or an
    out-of-range value raises ValueError with a one-line message.
    """
    params = {}
    for pair in pairs:
        key, _, value = pair.partition('=')
        try:   # without '=' the value is '', not a number either
            params[key] = float(value)
        except ValueError:
            raise ValueError(f'{pair!r}: expected KEY=NUMBER') from None
    _params(params)
    return params


def rig_from_command_line(parser, pairs, richsim_used=True):
    """
    Return `parse_rig(pairs)` for a script's repeatable `--param KEY=VALUE` option.

    A bad pair, or pairs when the rich simulator is not used, is a usage error of `parser`
    (one line, exit 2).
    """
    if pairs and not richsim_used:
        parser.error('--param needs --source richsim')
    try:
        return parse_rig(pairs)
    except ValueError as err:
        parser.error(f'--param: {err}')


def wire_row(pp, length_factor=1.0, strain_factor=1.0, h_factor=1.0, fatigue_kappa=1.0):
    """
    Per-wire properties (columns W_*) from geometry.

    R = r_l L, C = rho pi d^2/4 L c, A = pi d L, hA = f_h h A with h = C0/(tau0 A0) from the
    nominal wire (cooling time constant tau0), stroke = f_eps eps_L L.
    """
    d, length = pp['wire_diameter_m'], pp['wire_length_m'] * length_factor
    cap = pp['density_kg_m3'] * math.pi * d ** 2 / 4 * length * pp['specific_heat_j_kg_k']
    h = pp['density_kg_m3'] * d / 4 * pp['specific_heat_j_kg_k'] / pp['cooling_tau_s']
    row = np.zeros(N_WIRE_FIELDS)
    row[W_R] = pp['resistance_ohm_per_m'] * length
    row[W_C], row[W_AREA] = cap, math.pi * d * length
    row[W_HA], row[W_LEN] = h_factor * h * row[W_AREA], length
    row[W_STROKE] = strain_factor * pp['strain_max'] * length
    row[W_FATIGUE] = fatigue_kappa
    return row


def _effect_settings(effect, m, duration_s, rng):
    """(plant field overrides, wire-b geometry kwargs, hard fraction) for one effect."""
    if effect == 'saturation':
        return {}, {}, min(1.0, 0.5 * m)
    table = {
        'none': {},
        'fast_dynamics': {'tau_fast_s': 0.3 * m if 0.3 * m >= 5e-3 else 0.0},
        'delay': {'delay_s': 0.2 * m},
        'convection': {'conv_exp': 0.25 * m, 'emissivity': min(0.3 * m, 0.9)},
        'ambient_drift': {'amb_ramp_k_per_s': rng.choice([-1.0, 1.0]) * 6.0 * m / duration_s,
                          'amb_sine_k': 4.0 * m,
                          'amb_period_s': duration_s * rng.uniform(0.5, 1.0),
                          'amb_phase_rad': rng.uniform(0, 2 * math.pi)},
        'phase_resistance': {'rho_phase': 0.18 * m},
        'stress_coupling': {'stress_k_per_stroke': 10.0 * m},
        'sensor_nonlinearity': {'sens_gain': 0.05 * m},
        'fatigue_drift': {'fatigue_loss': 0.2 * m, 'fatigue_elong': 0.003 * m,
                          'fatigue_n0': 15.0 if m > 0 else 0.0},
        'current_limit': {'cl_knee_duty': 0.45 / m if m > 0 else 0.0},
        'asymmetric_wires': {},
    }
    wire_b = {}
    if effect == 'asymmetric_wires':
        wire_b = {'length_factor': 1 + 0.04 * m, 'strain_factor': 1 + 0.12 * m,
                  'h_factor': 1 - 0.08 * m}
    return table[effect], wire_b, 0.0


def build_plant(pp, effect='none', magnitude=1.0, duration_s=600.0, rng=None, also=()):
    """
    Plant namedtuple and (2, N_WIRE_FIELDS) wire array for `effect` at `magnitude`.

    also: further (effect, magnitude) pairs hidden in the same plant (`check_also`).
    """
    rng = np.random.default_rng(0) if rng is None else rng
    over, wire_b, hard = _effect_settings(effect, magnitude, duration_s, rng)
    for name, m in also:
        more, more_b, more_hard = _effect_settings(name, m, duration_s, rng)
        over, wire_b, hard = {**over, **more}, {**wire_b, **more_b}, max(hard, more_hard)
    base = {
        'supply_v': pp['supply_v'], 'i_max_a': pp['i_max_a'], 'pulley_r_m': pp['pulley_r_m'],
        'phi0_rad': pp['phi0_rad'], 'adc_half_range_rad': pp['adc_half_range_rad'],
        'adc_bits': pp['adc_bits'], 'cmd_dt_s': pp['cmd_dt_s'], 'kp': pp['kp'], 'ki': pp['ki'],
        'd0': pp['d0'], 'u_knee': pp['u_knee'], 'u_max': pp['duty_max'], 'delay_s': 0.0,
        'tau_fast_s': 0.0, 'fast_cap_frac': 0.5, 'conv_exp': 0.0, 'conv_ref_k': 50.0,
        'emissivity': 0.0, 'rho_phase': 0.0,
        'stress_k_per_stroke': 0.0, 'stress_self_weight': pp['stress_self_weight'],
        'fatigue_loss': 0.0, 'fatigue_elong': 0.0,
        'fatigue_n0': 0.0, 'cl_knee_duty': 0.0, 'cl_sharpness': 4.0, 'sens_gain': 0.0,
        'sens_sine': 0.8,
        'sens_quad': 0.4, 'amb0_c': pp['ambient_c'], 'amb_ramp_k_per_s': 0.0, 'amb_sine_k': 0.0,
        'amb_period_s': max(duration_s, 1.0), 'amb_phase_rad': 0.0}
    base.update(over)
    wires = np.vstack([wire_row(pp, fatigue_kappa=1.0),
                       wire_row(pp, fatigue_kappa=0.35, **wire_b)])
    return Plant(**{k: float(v) for k, v in base.items()}), wires, hard


_TABLES = {}


def _everett(pp):
    """Everett table for the hysteresis parameters in pp (memoised: ~7 MB, ~50 ms)."""
    names = ('hyst_centre_c', 'hyst_width_k', 'hyst_centre_sd_k', 'hyst_width_sd_k')
    key = tuple(pp[k] for k in names)
    if key not in _TABLES:
        _TABLES[key] = everett_table(*key)
    return _TABLES[key]


def _check_common(effect, magnitude, rate_hz, noise_rad, duration_s, seed):
    if effect not in EFFECTS:
        raise ValueError(f'effect={effect!r} unknown; choose one of {sorted(EFFECTS)}')
    m = _check_number('magnitude', magnitude, 0.0, MAX_MAGNITUDE)
    rate = _check_number('rate_hz', rate_hz, 1.0, 1000.0)
    noise = _check_number('noise_rad', noise_rad, 0.0, 0.5)
    dur = _check_number('duration_s', duration_s, 0.0, 36000.0, lo_open=True)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f'seed must be a non-negative integer, got {seed!r}')
    return m, rate, noise, dur


def check_also(effect, also):
    """
    Return the checked list of further hidden (effect, magnitude) pairs of `simulate`.

    Each is another catalog effect than `effect` and the others, not 'none' or 'saturation'
    (the excitation, not the plant); magnitudes as for `effect`.
    """
    out, seen = [], {effect}
    for pair in also or ():
        try:
            name, m = pair
        except (TypeError, ValueError):
            raise ValueError(f'also: expected (effect, magnitude) pairs, got {pair!r}') from None
        if name not in EFFECTS or name in ('none', 'saturation') or name in seen:
            raise ValueError(f'also: effect {name!r} must be another catalog effect than '
                             f"{sorted(seen)}, not 'none' or 'saturation'")
        seen.add(name)
        out.append((name, _check_number(f'also[{name!r}] magnitude', m, 0.0, MAX_MAGNITUDE)))
    return out


def _run_commands(pp, effect, m, rate, noise, dur, streams, closed, cmd, setp, also=()):
    """Integrate on the fine grid and package the per-sample arrays."""
    plant, wires, _ = build_plant(pp, effect, m, dur, streams['effect'], also)
    stride = max(1, int(math.ceil(1.0 / (rate * pp['fine_dt_s']) - 1e-9)))
    dt = 1.0 / (rate * stride)
    n_samples = int(round(dur * rate))
    n_steps = n_samples * stride
    tab, lo, step = _everett(pp)
    state = new_state(2, plant.amb0_c)
    sensor_noise = streams['noise'].standard_normal(n_steps) * noise
    out = run(plant, wires, tab, lo, step, state, n_steps, dt, stride, closed,
              np.ascontiguousarray(cmd[:, 0]), np.ascontiguousarray(cmd[:, 1]), setp, sensor_noise)
    amb_meas = out[6] + streams['ambient'].standard_normal(n_samples) * pp['ambient_noise_c']
    lsb = pp['ambient_lsb_c']
    data = {'time': np.arange(n_samples) / rate, 'duty_a': out[7], 'duty_b': out[8],
            'position': out[0], 'ambient_temperature': np.round(amb_meas / lsb) * lsb}
    if closed:
        data['setpoint'] = out[9]
    data.update({'true_position': out[1], 'true_temperature_a': out[2],
                 'true_temperature_b': out[3], 'true_austenite_a': out[4],
                 'true_austenite_b': out[5], 'true_ambient': out[6]})
    return data


def _streams(seed):
    """Independent RNG streams so one seed gives the same excitation/noise for every effect."""
    names = ('excitation', 'noise', 'ambient', 'effect')
    seqs = np.random.SeedSequence(int(seed)).spawn(len(names))
    return {n: np.random.default_rng(s) for n, s in zip(names, seqs)}


def simulate(effect='none', magnitude=1.0, excitation='open', duration_s=600, rate_hz=40,
             noise_rad=0.002, seed=0, params=None, layout='antagonistic', also=()):
    """
    Simulate one recording with hidden `effect` at `magnitude` (EFFECTS lists the ranges).

    excitation: 'open' (random duty sequences) or 'closed' (own PI at 25 ms tracking random
    setpoints). layout 'single' (open loop only): wire b is never heated, so wire a works
    against the loop tension alone, as one wire against a bias spring; duty_b is 0 and wire a
    takes the larger of the two commands. Returns a dict of equal-length arrays: time [s],
    duty_a, duty_b [0..1] (mean commanded duty over the following sample interval), position
    [rad] (potentiometer with noise_rad Gaussian noise and 12-bit ADC), ambient_temperature
    [degC] (measured), setpoint [rad] (closed loop only) and true_* hidden states for tests.
    also: further effects hidden at once, (effect, magnitude) pairs (`check_also`).
    """
    m, rate, noise, dur = _check_common(effect, magnitude, rate_hz, noise_rad, duration_s, seed)
    also = check_also(effect, also)
    if excitation not in EXCITATIONS:
        raise ValueError(f'excitation={excitation!r}; choose one of {EXCITATIONS}')
    if layout not in LAYOUTS or (layout == 'single' and excitation != 'open'):
        raise ValueError(f'layout={layout!r} with excitation={excitation!r}; choose one of '
                         f"{LAYOUTS} ('single' in open loop only)")
    pp = _params(params)
    streams = _streams(seed)
    hard = min(1.0, 0.5 * m) if effect == 'saturation' else 0.0
    dt_cmd = pp['cmd_dt_s']
    if excitation == 'open':
        cmd = exc.open_loop_duty(streams['excitation'], dur, dt_cmd, pp['duty_max'], hard)
        if layout == 'single':   # wire a also takes the sequences meant for wire b
            cmd[:, 0], cmd[:, 1] = cmd.max(axis=1), 0.0
        setp = np.zeros(cmd.shape[0])
    else:
        setp = exc.closed_loop_setpoint(streams['excitation'], dur, dt_cmd, hard=hard,
                                        hard_amplitude=1.1)
        cmd = np.zeros((setp.size, 2))
    closed = excitation == 'closed'
    return _run_commands(pp, effect, m, rate, noise, dur, streams, closed, cmd, setp, also)


def simulate_profile(duty_a, duty_b, effect='none', magnitude=1.0, rate_hz=40,
                     noise_rad=0.0, seed=0, params=None):
    """Open-loop run with user duty commands (one value per cmd_dt_s = 25 ms tick)."""
    cmd = np.column_stack([np.asarray(duty_a, float), np.asarray(duty_b, float)])
    if cmd.ndim != 2 or cmd.shape[0] < 2 or not np.all(np.isfinite(cmd)):
        raise ValueError('duty_a/duty_b must be equal-length finite 1-D sequences (>= 2 ticks)')
    if cmd.min() < 0 or cmd.max() > 1:
        raise ValueError('duty_a/duty_b must lie in [0, 1]')
    pp = _params(params)
    dur = cmd.shape[0] * pp['cmd_dt_s']
    m, rate, noise, dur = _check_common(effect, magnitude, rate_hz, noise_rad, dur, seed)
    return _run_commands(pp, effect, m, rate, noise, dur, _streams(seed), False, cmd,
                         np.zeros(cmd.shape[0]))


def write_csv(data, path):
    """Write time,duty_a,duty_b,position,ambient_temperature[,setpoint] with a header row."""
    missing = [c for c in CSV_COLUMNS[:5] if c not in data]
    if missing:
        raise ValueError(f'data: missing column(s) {missing}')
    cols = [c for c in CSV_COLUMNS if c in data]
    n = len(data['time'])
    if any(len(data[c]) != n for c in cols):
        raise ValueError(f'data: columns {cols} must have equal lengths')
    table = np.column_stack([np.asarray(data[c], float) for c in cols])
    np.savetxt(path, table, delimiter=',', header=','.join(cols), comments='',
               fmt=[_CSV_FMT[c] for c in cols])


def read_csv(path):
    """Read a CSV written by write_csv back into a dict of float arrays."""
    with open(path, encoding='utf-8') as fh:
        header = fh.readline().strip().split(',')
    if header[:4] != list(CSV_COLUMNS[:4]):
        raise ValueError(f'{path}: header {header} does not start with {CSV_COLUMNS[:4]}')
    table = np.loadtxt(path, delimiter=',', skiprows=1, ndmin=2)
    return {name: table[:, i] for i, name in enumerate(header)}
