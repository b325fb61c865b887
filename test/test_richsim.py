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

"""Behaviour of the rich, independent SMA simulator used to make hidden-effect test data."""
import math

import numpy as np
import pytest
from support import richsim
from support.make_hidden_dataset import main as cli_main
from support.richsim import EFFECTS, simulate, simulate_profile
from support.richsim_preisach import everett_table, new_state, preisach_step

TICK = 0.025            # command clock [s]
REQUIRED = ('none', 'saturation', 'fast_dynamics', 'delay', 'convection', 'ambient_drift',
            'phase_resistance', 'stress_coupling', 'asymmetric_wires', 'sensor_nonlinearity',
            'fatigue_drift', 'current_limit')


def profile(*segments):
    """Duty commands per 25 ms tick from (seconds, duty_a, duty_b) segments."""
    rows = [np.tile([a, b], (int(round(s / TICK)), 1)) for s, a, b in segments]
    cmd = np.vstack(rows)
    return cmd[:, 0], cmd[:, 1]


def steady_rise_k(duty, p=richsim.DEFAULTS):
    """
    Expect steady wire temperature rise [K] of the null model.

    dT = P / hA with P = d R min(V/R, I_max)^2, hA = C / tau, C = rho pi d^2/4 L c (re-derived
    independently).
    """
    r = p['resistance_ohm_per_m'] * p['wire_length_m']
    power = duty * r * min(p['supply_v'] / r, p['i_max_a']) ** 2
    cap = (p['density_kg_m3'] * math.pi * p['wire_diameter_m'] ** 2 / 4 * p['wire_length_m']
           * p['specific_heat_j_kg_k'])
    return power / (cap / p['cooling_tau_s'])


def run(effect, magnitude, *segments, rate_hz=40):
    return simulate_profile(*profile(*segments), effect=effect, magnitude=magnitude,
                            rate_hz=rate_hz, noise_rad=0.0)


def test_effects_catalog_is_complete_and_documented():
    assert set(EFFECTS) == set(REQUIRED)
    for name, info in EFFECTS.items():
        lo, hi = info['magnitude_range']
        assert info['description'] and 0.0 <= lo <= hi <= richsim.MAX_MAGNITUDE, name


@pytest.mark.slow
@pytest.mark.parametrize('duty', [0.1, 0.3])
def test_steady_state_temperature_is_p_over_ha(duty):
    d = run('none', 0.0, (15.0, duty, 0.0))
    rise = d['true_temperature_a'][-1] - richsim.DEFAULTS['ambient_c']
    assert rise == pytest.approx(steady_rise_k(duty), rel=1e-3)
    assert d['true_temperature_b'][-1] == pytest.approx(richsim.DEFAULTS['ambient_c'])


def test_cooling_follows_the_thermal_time_constant():
    d = run('none', 0.0, (12.0, 0.3, 0.0), (4.0, 0.0, 0.0))
    t, th = d['time'], d['true_temperature_a'] - richsim.DEFAULTS['ambient_c']
    k0, k1 = np.searchsorted(t, [12.5, 14.5])
    tau = (t[k1] - t[k0]) / math.log(th[k0] / th[k1])
    assert tau == pytest.approx(richsim.DEFAULTS['cooling_tau_s'], rel=1e-3)


def crossing(temp, frac, level):
    """Temperature at which the monotone branch `frac` first crosses `level`."""
    k = np.argmax(frac >= level) if frac[-1] > frac[0] else np.argmax(frac <= level)
    return temp[k]


def test_major_loop_has_the_documented_transformation_temperatures():
    # slow sweep (0.004 duty/s, ~0.7 K/s): quasi-static heating then cooling branch
    up = np.linspace(0.0, 0.45, 4000)
    da = np.r_[up, up[::-1]]
    d = simulate_profile(da, np.zeros_like(da), noise_rad=0.0, rate_hz=20)
    half = d['time'].size // 2
    temp, aus = d['true_temperature_a'], d['true_austenite_a']
    heat, cool = slice(0, half), slice(half, None)
    assert crossing(temp[heat], aus[heat], 0.01) == pytest.approx(68.0, abs=1.5)   # As
    assert crossing(temp[heat], aus[heat], 0.99) == pytest.approx(78.0, abs=1.5)   # Af
    assert crossing(temp[cool], aus[cool], 0.99) == pytest.approx(52.0, abs=1.5)   # Ms
    assert crossing(temp[cool], aus[cool], 0.01) == pytest.approx(42.0, abs=1.5)   # Mf
    assert aus[-1] < 1e-3 and aus.max() > 0.999          # the major loop closes


def test_preisach_minor_loops_nest_and_have_return_point_memory():
    tab, lo, step = everett_table()
    state = new_state(1, 22.0)

    def walk(seq):
        return [preisach_step(state, 0, tab, lo, step, u) for u in seq]

    heat1 = walk(np.linspace(22, 73, 200))           # partial heating: a ~ 0.5
    cool = walk(np.linspace(73, 47, 200))            # partial cooling, stays above Mf
    heat2 = walk(np.linspace(47, 73, 200))           # back to the same maximum
    assert 0.3 < heat1[-1] < 0.7
    assert 0.05 < cool[-1] < heat1[-1] - 0.1         # cooling reverted part of it
    assert heat2[-1] == pytest.approx(heat1[-1], abs=1e-9)   # return-point memory
    mid = 100                                        # ~60 degC on both legs: loop has area
    assert cool[::-1][mid] - heat2[mid] > 0.05
    assert heat1[-1] < walk([78.5])[0] - 0.4         # exceeding the max wipes the loop out


def test_magnitude_zero_reproduces_the_null_model():
    segs = ((4, 0.3, 0.0), (3, 0.0, 0.1), (4, 0.0, 0.45), (3, 0.0, 0.0))
    base = run('none', 0.0, *segs)
    for effect in REQUIRED:
        d = run(effect, 0.0, *segs)
        np.testing.assert_array_equal(d['position'], base['position'], err_msg=effect)


def t_half(d):
    p = d['true_position']
    return d['time'][np.argmax(p > p[0] + 0.5 * (p.max() - p[0]))]


def test_fast_dynamics_adds_a_lag_of_about_tau():
    base = t_half(run('none', 0.0, (8, 0.4, 0.0), rate_hz=100))
    for m in (1.0, 2.0):
        shift = t_half(run('fast_dynamics', m, (8, 0.4, 0.0), rate_hz=100)) - base
        assert 0.7 * 0.3 * m < shift < 1.6 * 0.3 * m


def test_delay_shifts_the_whole_open_loop_response():
    segs = ((3, 0.3, 0.0), (4, 0.0, 0.45), (2, 0.1, 0.0), (3, 0.0, 0.0))
    base, late = run('none', 0.0, *segs), run('delay', 1.0, *segs)   # 0.2 s = 8 samples
    np.testing.assert_allclose(late['true_position'][8:], base['true_position'][:-8], atol=1e-9)
    assert np.abs(late['true_position'] - base['true_position']).max() > 0.1
    np.testing.assert_array_equal(late['duty_a'], base['duty_a'])      # command is logged


@pytest.mark.parametrize('duty, hotter', [(0.1, True), (0.45, False)])
def test_convection_cools_less_near_ambient_and_more_when_hot(duty, hotter):
    t_none = run('none', 0.0, (15, duty, 0.0))['true_temperature_a'][-1]
    t_conv = run('convection', 1.0, (15, duty, 0.0))['true_temperature_a'][-1]
    assert (t_conv > t_none + 1.0) if hotter else (t_conv < t_none - 1.0)


def test_phase_resistance_lowers_power_in_austenite_only():
    effects = ('none', 'phase_resistance')
    cold = [run(e, 1.0, (15, 0.1, 0.0))['true_temperature_a'][-1] for e in effects]
    assert cold[1] == pytest.approx(cold[0], abs=1e-6)            # martensite: R = R_M
    hot = [run(e, 1.0, (15, 0.45, 0.0)) for e in effects]
    assert hot[1]['true_austenite_a'][-1] > 0.999
    ratio = [(h['true_temperature_a'][-1] - 22.0) for h in hot]
    assert ratio[1] / ratio[0] == pytest.approx(1 / 1.18, rel=0.01)   # P ~ R in current limit


def test_stress_coupling_raises_transformation_temperatures():
    segs = ((6, 0.0, 0.45), (6, 0.29, 0.0))        # antagonist contracted, then partial heat
    base, stressed = run('none', 0.0, *segs), run('stress_coupling', 1.0, *segs)
    k = np.searchsorted(base['time'], 7.0)         # b still hot, a just heating
    assert stressed['true_austenite_a'][-1] < base['true_austenite_a'][-1] - 0.1
    assert stressed['true_temperature_a'][-1] == pytest.approx(base['true_temperature_a'][-1])
    assert base['true_austenite_b'][k] > 0.5


def test_asymmetric_wires_give_wire_b_a_longer_stroke():
    segs = ((8, 0.45, 0.0), (6, 0.0, 0.0), (8, 0.0, 0.45), (6, 0.0, 0.0))
    base, asym = run('none', 0.0, *segs), run('asymmetric_wires', 1.0, *segs)
    assert asym['true_position'].max() == pytest.approx(base['true_position'].max(), abs=1e-3)
    phi0 = richsim.DEFAULTS['phi0_rad']
    ratio = (asym['true_position'].min() - phi0) / (base['true_position'].min() - phi0)
    assert ratio == pytest.approx(1.12 * 1.04, rel=0.01)


def test_sensor_nonlinearity_is_a_monotone_few_percent_error():
    up = np.linspace(0.0, 0.45, 1600)
    segs = np.r_[up, np.zeros(800)], np.r_[np.zeros(1600), up[:800]]
    for m, lo, hi in ((0.0, 0.0, 0.002), (1.0, 0.03, 0.06)):
        d = simulate_profile(*segs, effect='sensor_nonlinearity', magnitude=m, noise_rad=0.0)
        err = d['position'] - d['true_position']
        assert lo < np.abs(err).max() / 2.4 < hi                    # fraction of full scale
    order = np.argsort(d['true_position'])
    assert np.all(np.diff(d['position'][order]) > -1e-3)            # monotone up to 2 LSB


def test_fatigue_shrinks_the_stroke_and_drifts_the_rest_position():
    segs = ((5, 0.45, 0.0), (5, 0.0, 0.0)) * 12
    runs = {e: run(e, 1.0, *segs)['true_position'].reshape(12, -1)
            for e in ('none', 'fatigue_drift')}
    strokes = {e: p.max(axis=1) - p.min(axis=1) for e, p in runs.items()}
    assert np.ptp(strokes['none']) < 1e-6 and np.ptp(runs['none'][:, -1]) < 1e-6
    first, last = strokes['fatigue_drift'][[0, -1]]
    assert 0.8 * first < last < 0.93 * first                  # ~11 % loss after 12 cycles
    rest = runs['fatigue_drift'][:, -1]                        # wire a elongates: angle drops
    assert rest[-1] < rest[0] - 0.01 and np.all(np.diff(rest) < 0)


def test_current_limit_saturates_power_at_high_duty():
    rise = {}
    for duty in (0.1, 0.45):
        t = [run(e, 1.0, (15, duty, 0.0))['true_temperature_a'][-1] - 22
             for e in ('none', 'current_limit')]
        rise[duty] = t[1] / t[0]
    assert rise[0.1] > 0.99 and rise[0.45] < 0.85


def test_ambient_drift_is_measured_and_drives_the_wire_temperature():
    drift = simulate('ambient_drift', 1.0, 'open', duration_s=120, seed=2)
    flat = simulate('none', 1.0, 'open', duration_s=120, seed=2)
    assert np.ptp(flat['ambient_temperature']) < 0.5
    assert np.ptp(drift['true_ambient']) > 5.0
    assert np.abs(drift['ambient_temperature'] - drift['true_ambient']).max() < 0.3
    cold = (drift['duty_a'] == 0) & (flat['duty_a'] == 0) & (drift['time'] > 60)
    cold &= np.r_[False, cold[:-1]] & np.r_[False, False, cold[:-2]]   # settled a bit
    lag = drift['true_temperature_a'] - drift['true_ambient'] - (flat['true_temperature_a'] - 22.0)
    assert np.abs(lag[cold]).mean() < 0.5 * np.abs(drift['true_ambient'][cold] - 22.0).mean()


def near_ends(d):
    return np.mean(np.abs(d['true_position'] - richsim.DEFAULTS['phi0_rad']) > 0.95)


@pytest.mark.parametrize('excitation', ['open', 'closed'])
def test_saturation_drives_both_ends_of_travel_more_often(excitation):
    base = simulate('none', 1.0, excitation, duration_s=300, seed=4)
    hard = simulate('saturation', 1.0, excitation, duration_s=300, seed=4)
    assert near_ends(hard) > near_ends(base) + 0.1
    assert hard['true_position'].max() > 0.95 and hard['true_position'].min() < -0.9


def turning_points(aus, lo=0.1, hi=0.9, eps=0.02):
    """Return the number of direction reversals of the austenite fraction inside (lo, hi)."""
    count, ref, direction = 0, aus[0], 0
    for a in aus:
        step = a - ref
        if abs(step) > eps:
            new = 1 if step > 0 else -1
            count += direction != 0 and new != direction and lo < ref < hi
            ref, direction = a, new
        elif (direction > 0 and a > ref) or (direction < 0 and a < ref):
            ref = a
    return count


@pytest.mark.parametrize('excitation', ['open', 'closed'])
def test_excitation_covers_loops_and_keeps_wires_sane(excitation):
    d = simulate('none', 1.0, excitation, duration_s=600, seed=0)
    assert not np.any((d['duty_a'] > 0.2) & (d['duty_b'] > 0.2))
    for w in 'ab':
        temp, aus = d[f'true_temperature_{w}'], d[f'true_austenite_{w}']
        assert temp.max() < 130.0
        assert turning_points(aus) >= 5                              # minor loops
        assert np.mean((aus > 0.05) & (aus < 0.95)) > 0.05           # time inside the band
        if excitation == 'open':
            assert aus.max() > 0.99                                  # full transformation
    if excitation == 'closed':
        sp = d['setpoint']
        assert np.abs(sp).max() <= 0.6 + 1e-12
        assert np.corrcoef(sp, d['position'])[0, 1] > 0.6             # rough PI tracking
    else:
        assert d['position'].max() > 0.95 and d['position'].min() < -0.9


def test_single_layout_works_one_wire_through_its_own_loop():
    pair = simulate('none', 1.0, 'open', duration_s=600, seed=0)
    one = simulate('none', 1.0, 'open', duration_s=600, seed=0, layout='single')
    assert not np.any(one['duty_b']) and np.any(pair['duty_b'])
    # wire a takes the larger command; wire b stays cold, so the shaft follows wire a alone
    np.testing.assert_allclose(one['duty_a'], np.maximum(pair['duty_a'], pair['duty_b']))
    assert one['true_austenite_b'].max() < 1e-9
    aus = one['true_austenite_a']
    assert aus.max() > 0.99 and turning_points(aus) >= 5
    assert np.corrcoef(aus, one['true_position'])[0, 1] > 0.999
    assert one['position'].min() > one['true_position'][0] - 0.02


def test_two_hidden_effects_at_once_act_together_in_either_order():
    kw = {'duration_s': 120, 'seed': 6}
    both = simulate('delay', 1.0, also=[('current_limit', 1.0)], **kw)
    swapped = simulate('current_limit', 1.0, also=[('delay', 1.0)], **kw)
    np.testing.assert_array_equal(both['position'], swapped['position'])
    for alone in (simulate('delay', 1.0, **kw), simulate('current_limit', 1.0, **kw)):
        assert np.abs(both['true_position'] - alone['true_position']).max() > 0.05


def test_runs_are_reproducible_per_seed():
    a = simulate('convection', 1.0, 'closed', duration_s=60, seed=7)
    b = simulate('convection', 1.0, 'closed', duration_s=60, seed=7)
    c = simulate('convection', 1.0, 'closed', duration_s=60, seed=8)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    assert not np.array_equal(a['setpoint'], c['setpoint'])


@pytest.mark.parametrize('rate', [20, 30, 100])
def test_sample_grid_and_logged_duty_follow_the_rate(rate):
    da, db = profile((1.0, 0.2, 0.0), (1.0, 0.0, 0.3), (1.0, 0.0, 0.0))
    d = simulate_profile(da, db, rate_hz=rate, noise_rad=0.0)
    assert d['time'].size == 3 * rate
    np.testing.assert_allclose(np.diff(d['time']), 1.0 / rate, rtol=1e-9)
    # mean commanded duty over each sample interval integrates to the command energy
    assert d['duty_a'].sum() / rate == pytest.approx(0.2, abs=1e-9)
    assert d['duty_b'].sum() / rate == pytest.approx(0.3, abs=1e-9)


def test_noise_and_adc_quantisation_are_applied():
    d = simulate('none', 1.0, 'open', duration_s=60, noise_rad=0.01, seed=1)
    err = d['position'] - d['true_position']
    assert np.std(err) == pytest.approx(0.01, rel=0.1)
    lsb = 2.4 / 4096
    codes = (d['position'] + 1.2) / lsb - 0.5
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-6)


@pytest.mark.parametrize('excitation, ncols', [('open', 5), ('closed', 6)])
def test_csv_round_trip(tmp_path, excitation, ncols):
    d = simulate('delay', 0.5, excitation, duration_s=20, rate_hz=30, seed=3)
    path = tmp_path / 'run.csv'
    richsim.write_csv(d, path)
    header = path.read_text().splitlines()[0].split(',')
    assert header == list(richsim.CSV_COLUMNS[:ncols])
    back = richsim.read_csv(path)
    for key in header:
        np.testing.assert_allclose(back[key], d[key], atol=1e-4, err_msg=key)


@pytest.mark.parametrize('kwargs, name', [
    ({'effect': 'wobble'}, 'effect'),
    ({'magnitude': -0.1}, 'magnitude'),
    ({'magnitude': float('nan')}, 'magnitude'),
    ({'excitation': 'random'}, 'excitation'),
    ({'rate_hz': 0}, 'rate_hz'),
    ({'noise_rad': -1}, 'noise_rad'),
    ({'duration_s': 0}, 'duration_s'),
    ({'seed': -3}, 'seed'),
    ({'params': {'kq': 1.0}}, 'kq'),
    ({'params': {'cooling_tau_s': 0.0}}, 'cooling_tau_s'),
    ({'layout': 'triple'}, 'layout'),
    ({'layout': 'single', 'excitation': 'closed'}, 'layout'),
    ({'effect': 'delay', 'also': [('delay', 1.0)]}, 'also'),
    ({'also': [('saturation', 1.0)]}, 'also'),
    ({'also': [('convection', -1.0)]}, 'also'),
    ({'also': ['convection']}, 'also'),
])
def test_bad_arguments_name_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        simulate(**{'duration_s': 5, **kwargs})


def test_rig_parameters_from_the_command_line_are_parsed_and_checked():
    assert richsim.parse_rig(['wire_length_m=0.3', 'hyst_centre_c=-5']) == {
        'wire_length_m': 0.3, 'hyst_centre_c': -5.0}
    assert richsim.parse_rig([]) == {}
    for pair, name in (('wire_length_m', 'KEY=NUMBER'), ('wire_length_m=long', 'KEY=NUMBER'),
                       ('kq=1', 'kq'), ('cooling_tau_s=0', 'cooling_tau_s')):
        with pytest.raises(ValueError, match=name):
            richsim.parse_rig([pair])


def test_write_csv_rejects_incomplete_data(tmp_path):
    with pytest.raises(ValueError, match='ambient_temperature'):
        richsim.write_csv({'time': [0.0], 'duty_a': [0], 'duty_b': [0], 'position': [0]},
                          tmp_path / 'x.csv')


def test_cli_writes_a_dataset_and_rejects_bad_magnitude(tmp_path, capsys):
    out = tmp_path / 'h' / 'fatigue_drift_closed.csv'
    args = ['--effect', 'fatigue_drift', '--excitation', 'closed', '--rate-hz', '25',
            '--duration-s', '10', '--seed', '1', '--out', str(out)]
    assert cli_main(args) == 0
    data = richsim.read_csv(out)
    assert data['time'].size == 250 and 'setpoint' in data
    assert cli_main(args[:-2] + ['--magnitude', '7', '--out', str(out)]) == 2
    assert 'magnitude' in capsys.readouterr().err


def test_logged_closed_loop_duty_replays_the_recorded_response():
    """
    Duty is logged as the command over the following sample.

    At the 40 Hz command rate, replaying it open loop through the same plant reproduces the
    closed-loop angle.
    """
    d = simulate('none', 1.0, 'closed', duration_s=60, rate_hz=40, seed=5)
    replay = simulate_profile(d['duty_a'], d['duty_b'], rate_hz=40, noise_rad=0.0)
    np.testing.assert_allclose(replay['true_position'], d['true_position'], atol=1e-9)
    assert np.ptp(d['true_position']) > 0.3
