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

"""Thermal dynamics of eq. (7), the antagonistic actuator's effects, and the potentiometer."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from sma_actuator.core import actuator as act
from sma_actuator.core.hysteresis import PlayHysteresis
from sma_actuator.core.sensor import Potentiometer
from sma_actuator.core.thermal import heating_power_w, on_current_a, thermal_step

ODE_TOL = 1e-11
AGREE_K = 1e-7   # kelvin: an exact discretisation agrees with a 1e-11 ODE solve far below this


def ode_one(theta0, amb, q_inf, dt, tau):
    """Return the reference solution of T dθ/dt = −(θ − θa) + G d over one held sample."""
    sol = solve_ivp(lambda _, x: [(-(x[0] - amb) + q_inf) / tau], (0, dt), [theta0],
                    method='DOP853', rtol=ODE_TOL, atol=ODE_TOL)
    return sol.y[0, -1]


def ode_two(theta0, q0, amb, q_inf, dt, tau, tau_f):
    """
    Return the reference solution of the two-lag model over one held sample.

    τ dq/dt = −q + G d, T dθ/dt = −(θ − θa) + q.
    """
    sol = solve_ivp(lambda _, x: [(-(x[0] - amb) + x[1]) / tau, (q_inf - x[1]) / tau_f],
                    (0, dt), [theta0, q0], method='DOP853', rtol=ODE_TOL, atol=ODE_TOL)
    return sol.y[0, -1], sol.y[1, -1]


@pytest.mark.parametrize('dt', [1e-3, 0.025, 0.5, 3.0, 20.0])
def test_exact_step_matches_ode_for_any_dt(dt):
    for theta0, q_inf in ((22.0, 141.0), (95.0, 0.0), (60.0, 35.0)):
        theta, q = thermal_step(theta0, 0.0, 22.0, q_inf, dt, 2.0, 0.0)
        assert abs(theta - ode_one(theta0, 22.0, q_inf, dt, 2.0)) < AGREE_K
        assert q == q_inf


@pytest.mark.parametrize('tau_f', [0.3, 2.0, 5.0])   # 2.0 = T exercises the τ → T limit
@pytest.mark.parametrize('dt', [0.025, 0.7, 6.0])
def test_two_lag_step_matches_ode(dt, tau_f):
    theta, q = 30.0, 10.0
    theta_ref, q_ref = theta, q
    for q_inf in (141.0, 0.0, 50.0):       # piecewise-constant duty over three samples
        theta, q = thermal_step(theta, q, 22.0, q_inf, dt, 2.0, tau_f)
        theta_ref, q_ref = ode_two(theta_ref, q_ref, 22.0, q_inf, dt, 2.0, tau_f)
        assert abs(theta - theta_ref) < AGREE_K
        assert abs(q - q_ref) < AGREE_K


@pytest.mark.parametrize('tau_f', [0.0, 0.4])
def test_steady_state_is_ambient_plus_gain_times_duty(tau_f):
    gain, duty, amb = 141.0, 0.37, 22.0
    theta, q = amb, 0.0
    for _ in range(400):                   # 400 x 0.5 s = 100 T
        theta, q = thermal_step(theta, q, amb, gain * duty, 0.5, 2.0, tau_f)
    assert abs(theta - (amb + gain * duty)) < 1e-9


def test_current_limiter_and_heating_power():
    # V/R = 5/13.75 = 0.364 A is limited to 0.35 A; 2 V gives 0.145 A, below the limit
    assert on_current_a(5.0, 13.75, 0.35) == 0.35
    assert on_current_a(2.0, 13.75, 0.35) == pytest.approx(2.0 / 13.75)
    assert heating_power_w(1.0, 5.0, 13.75, 0.35) == pytest.approx(13.75 * 0.35 ** 2)
    assert heating_power_w(0.5, 2.0, 13.75, 0.35) == pytest.approx(0.5 * 2.0 ** 2 / 13.75)
    assert heating_power_w(0.0, 5.0, 13.75, 0.35) == 0.0
    p = act.ActuatorParams()
    assert p.gain_k == pytest.approx(p.resistance_ohm * 0.35 ** 2 / p.conductance_w_per_k)


def duty_pattern(n, dt, seed=0):
    """Alternating multilevel duty on one wire at a time, 2-4 s holds."""
    rng = np.random.default_rng(seed)
    da, db = np.zeros(n), np.zeros(n)
    k, wire = 0, 0
    while k < n:
        m = int(rng.uniform(2, 4) / dt)
        (da if wire == 0 else db)[k:k + m] = rng.choice([0.0, 0.2, 0.35, 0.5, 0.7])
        k, wire = k + m, 1 - wire
    return da, db


def test_streaming_step_equals_batch_simulate():
    params = act.ActuatorParams(tau_fast_s=0.2, phase_kappa=0.3, stress_k=4.0, latent_heat_k=5.0,
                                convection_exponent=0.25, delay_s=0.05)
    dt, sub = 0.025, 5                     # the actuator splits 25 ms into 5 ms sub-steps
    da, db = duty_pattern(800, dt)
    plant = act.AntagonisticActuator(params, max_substep_s=dt / sub)
    stream = np.array([plant.step(a, b, dt) for a, b in zip(da, db)])
    fine = act.simulate(params, np.repeat(da, sub), np.repeat(db, sub), dt / sub)
    # batch sample k is the state before duty k acts: the stream's k-th return is sample k+1
    np.testing.assert_allclose(stream[:-1], fine.position_rad[sub::sub], atol=1e-9)


def test_strided_and_read_only_arrays_reuse_the_compiled_kernel_and_give_the_same_output():
    da, db = duty_pattern(400, 0.025)
    ambient = 21.0 + 0.01 * np.arange(400.0)
    r, lo, hi = np.array([[0.5, 40.0, 70.0], [2.0, 35.0, 75.0], [4.0, 30.0, 80.0]]).T
    params = act.ActuatorParams(latent_heat_k=2.0).with_changes(
        hysteresis=PlayHysteresis(r, lo, hi, np.array([0.3, 0.4, 0.3])))
    plain = run(params, da.copy(), db.copy(), 0.025, ambient_c=ambient.copy())
    compiled = set(act.simulate_wires.signatures)
    columns = np.stack([da, db, ambient], axis=1)   # each column a strided view
    read_only = ambient.copy()
    read_only.flags.writeable = False
    for amb in (columns[:, 2], read_only, np.broadcast_to(ambient, (400,))):
        other = run(params, columns[:, 0], columns[:, 1], 0.025, ambient_c=amb)
        np.testing.assert_array_equal(other.position_rad, plain.position_rad)
    assert set(act.simulate_wires.signatures) == compiled


def run(params, da, db, dt=0.05, **kw):
    """Batch simulation shortcut."""
    return act.simulate(params, da, db, dt, **kw)


def step_on_a(n=1000, level=0.5):
    """Wire a switched on at t = 1 s (dt 0.05 s, 50 s = 25 T long), wire b off."""
    da = np.zeros(n)
    da[20:] = level
    return da, np.zeros(n)


BASE = act.ActuatorParams()


def test_delay_shifts_the_response():
    da, db = step_on_a()
    y0 = run(BASE, da, db).position_rad
    y1 = run(BASE.with_changes(delay_s=0.5), da, db).position_rad
    np.testing.assert_allclose(y1[10:], y0[:-10], atol=1e-12)   # 0.5 s = 10 samples


def test_duty_limit_lowers_steady_temperature():
    da, db = step_on_a(level=1.0)
    t0 = run(BASE, da, db).theta_a_c[-1]
    t1 = run(BASE.with_changes(duty_limit=0.5), da, db).theta_a_c[-1]
    assert t0 == pytest.approx(BASE.ambient_c + BASE.gain_k, abs=1e-3)
    assert t1 == pytest.approx(BASE.ambient_c + 0.5 * BASE.gain_k, abs=1e-3)


def test_convection_moves_the_temperature_to_its_fixed_point():
    n = 0.3
    gd = 0.5 * BASE.gain_k                      # 70 K excess without convection
    da, db = step_on_a(level=0.5)
    hot = run(BASE.with_changes(convection_exponent=n), da, db).theta_a_c[-1]
    # steady state of hA(θ) = hA_ref (x / 50 K)^n: x (x / 50)^n = G d
    x = brentq(lambda x: x * (x / act.CONVECTION_REF_K) ** n - gd, 1.0, 200.0)
    assert hot == pytest.approx(BASE.ambient_c + x, abs=1e-3)
    assert hot < BASE.ambient_c + gd - 5        # above 50 K excess the wire settles cooler
    warm = run(BASE.with_changes(convection_exponent=n), *step_on_a(level=0.2)).theta_a_c[-1]
    x = brentq(lambda x: x * (x / act.CONVECTION_REF_K) ** n - 0.2 * BASE.gain_k, 1.0, 200.0)
    assert warm == pytest.approx(BASE.ambient_c + x, abs=1e-3)
    assert warm > BASE.ambient_c + 0.2 * BASE.gain_k + 1   # below it, warmer


def time_to_half(y, dt=0.05):
    """First time [s] the sequence reaches half of its final value."""
    return np.argmax(y >= 0.5 * y[-1]) * dt


def test_stress_coupling_delays_transformation():
    n = 600
    db = np.full(n, 0.6)                   # antagonist hot and contracted throughout
    da = np.zeros(n)
    da[200:] = 0.45
    t0 = time_to_half(run(BASE, da, db).y_a)
    t1 = time_to_half(run(BASE.with_changes(stress_k=8.0), da, db).y_a)
    assert t1 > t0 + 0.1


def test_phase_resistance_heats_martensite_faster():
    da, db = step_on_a(level=0.5)
    a = run(BASE, da, db)
    b = run(BASE.with_changes(phase_kappa=0.5), da, db)
    assert b.theta_a_c[30] > a.theta_a_c[30] + 1.0
    assert b.y_a[-1] == pytest.approx(1.0, abs=1e-6)     # fully contracted: no extra power
    assert b.theta_a_c[-1] == pytest.approx(a.theta_a_c[-1], abs=1e-3)


def test_latent_heat_slows_both_transformations_and_not_the_ends():
    n = 1600
    da, db = np.zeros(n), np.zeros(n)
    da[20:800] = 0.5                                      # heat 39 s, then cool 40 s
    a = run(BASE, da, db)
    b = run(BASE.with_changes(latent_heat_k=20.0), da, db)

    def crossing(y, start, rising):
        return start + np.argmax(y[start:] > 0.5 if rising else y[start:] < 0.5)
    assert crossing(b.y_a, 20, True) > crossing(a.y_a, 20, True) + 4      # > 0.2 s later
    assert crossing(b.y_a, 800, False) > crossing(a.y_a, 800, False) + 4
    # transformed through, the wire is back on the heat balance of eq. (7)
    assert b.y_a[790] == pytest.approx(a.y_a[790], abs=1e-6)
    assert b.theta_a_c[790] == pytest.approx(a.theta_a_c[790], abs=1e-2)
    assert b.theta_a_c[-1] == pytest.approx(a.theta_a_c[-1], abs=1e-2)


def steep_loop_params(latent_k):
    """Flexinol defaults with a steep, narrow loop (0.5 K half-widths over 60-64 °C)."""
    centres = np.linspace(60.0, 64.0, 9)
    loop = PlayHysteresis(np.full(9, 0.5), centres - 0.25, centres + 0.25, np.full(9, 2.0))
    return BASE.with_changes(hysteresis=loop, latent_heat_k=latent_k)


def test_latent_heat_is_taken_at_the_samples_end_so_a_steep_loop_does_not_chatter():
    # λ dH/dθ = 40 K x 2 per K: an explicit θ − λ Δy overshoots by far in every sample
    da = np.linspace(0.0, 0.5, 2000)
    db = np.zeros_like(da)
    t = run(steep_loop_params(40.0), da, db)
    # heating only: the contraction never falls back
    assert np.diff(t.y_a).min() > -1e-9
    # each sample's heat balance holds at its end: θ + λ y is what the thermal step gives
    p = steep_loop_params(40.0)
    for k in (600, 900, 1200):
        theta_pred, _ = thermal_step(t.theta_a_c[k], 0.0, p.ambient_c, p.gain_k * da[k], 0.05,
                                     p.tau_s, 0.0)
        assert t.theta_a_c[k + 1] + 40.0 * t.y_a[k + 1] == pytest.approx(
            theta_pred + 40.0 * t.y_a[k], abs=1e-8)


def test_the_response_is_smooth_in_the_latent_heat():
    # a fit differentiates the free-run output numerically: the derivative must not depend
    # on the step (a latent heat that chatters from sample to sample makes it grow as 1 / step)
    da = np.r_[np.linspace(0.0, 0.5, 1000), np.linspace(0.5, 0.0, 1000)]
    db = np.zeros_like(da)

    def slope(h):
        y0 = run(steep_loop_params(10.0), da, db).position_rad
        y1 = run(steep_loop_params(10.0 + h), da, db).position_rad
        return np.linalg.norm(y1 - y0) / h
    assert slope(1e-6) == pytest.approx(slope(1e-3), rel=0.05)


def test_fast_dynamics_slow_the_start_only():
    da, db = step_on_a()
    a = run(BASE, da, db)
    b = run(BASE.with_changes(tau_fast_s=0.5), da, db)
    assert b.theta_a_c[26] < a.theta_a_c[26] - 1.0
    assert b.theta_a_c[-1] == pytest.approx(a.theta_a_c[-1], abs=1e-3)


def test_wire_b_ratios_change_wire_b_only():
    n = 400
    da, db = np.full(n, 0.4), np.zeros(n)
    db[100:] = 0.4
    a = run(BASE, da, db)
    for change in ({'gain_ratio_b': 0.6}, {'tau_ratio_b': 2.0}):
        b = run(BASE.with_changes(**change), da, db)
        np.testing.assert_array_equal(b.theta_a_c, a.theta_a_c)
        assert (b.theta_b_c[110:200] < a.theta_b_c[110:200] - 1.0).all()


def test_stroke_ratio_scales_wire_b_travel():
    n = 300
    da, db = np.zeros(n), np.full(n, 0.6)
    a = run(BASE, da, db).position_rad[-1]
    b = run(BASE.with_changes(stroke_ratio_b=0.7), da, db).position_rad[-1]
    assert a < -0.9 and b == pytest.approx(0.7 * a, rel=1e-6)


def test_ambient_gain_weights_measured_ambient():
    da, db = step_on_a(level=0.2)
    warm = np.full(len(da), BASE.ambient_c + 5.0)
    t1 = run(BASE, da, db, ambient_c=warm).theta_a_c[-1]
    t0 = run(BASE.with_changes(ambient_gain=0.0), da, db, ambient_c=warm).theta_a_c[-1]
    assert t1 - t0 == pytest.approx(5.0, abs=1e-3)


def test_sensor_inverse_is_exact_on_the_rising_branch_and_first_order_beyond():
    # the plant's strongest setting: the first-order inverse 2y - p(y) is off by 0.26 rad
    p = BASE.with_changes(sensor_c2_rad=0.15, sensor_c3_rad=-0.1, sensor_c4_rad=0.05)
    phi = np.linspace(-1.1, 1.1, 501)
    reading = act.sensor_polynomial(p, phi)
    np.testing.assert_allclose(act.sensor_inverse(p, reading), phi, atol=1e-5)
    assert np.max(np.abs(2 * reading - act.sensor_polynomial(p, reading) - phi)) > 0.1
    for y in (-0.6, 0.3, 1.0):      # cross-check one value with a scalar root finder
        root = brentq(lambda f: float(act.sensor_polynomial(p, f)) - y, -1.1, 1.5)
        assert act.sensor_inverse(p, np.array([y, -0.5, 1.2]))[0] == pytest.approx(root, abs=1e-6)
    # p turns within the readings (c5 = -0.15 with c2 = 0.25 falls below -1.1 rad): no
    # single-valued inverse, so the first-order one
    bent = BASE.with_changes(sensor_c2_rad=0.25, sensor_c5_rad=-0.15)
    y = np.linspace(-1.2, 1.2, 50)
    np.testing.assert_allclose(act.sensor_inverse(bent, y), 2 * y - act.sensor_polynomial(bent, y))
    np.testing.assert_array_equal(act.sensor_inverse(BASE, y), y)     # no polynomial


def test_sensor_polynomial_is_expanded_about_the_travel_in_any_unit():
    # eq. step 5: p(φ) = φ + h Σ c_k x^k, x = (φ − φc) / h
    terms = {'sensor_c2_rad': 0.1, 'sensor_c3_rad': -0.2, 'sensor_c4_rad': 0.05,
             'sensor_c5_rad': 0.1}
    rad = BASE.with_changes(sensor_centre_rad=0.2, sensor_half_span_rad=0.6, **terms)
    phi = np.linspace(-0.4, 0.8, 61)
    x = (phi - 0.2) / 0.6
    expected = phi + 0.6 * (0.1 * x ** 2 - 0.2 * x ** 3 + 0.05 * x ** 4 + 0.1 * x ** 5)
    np.testing.assert_allclose(act.sensor_polynomial(rad, phi), expected, atol=1e-12)
    # the same potentiometer read in mm (8 mm + 5 mm/rad): the same terms, travel moved
    mm = BASE.with_changes(sensor_centre_rad=8.0 + 5.0 * 0.2, sensor_half_span_rad=5.0 * 0.6,
                           **terms)
    np.testing.assert_allclose(act.sensor_polynomial(mm, 8.0 + 5.0 * phi), 8.0 + 5.0 * expected,
                               atol=1e-12)
    np.testing.assert_allclose(act.sensor_inverse(mm, 8.0 + 5.0 * expected), 8.0 + 5.0 * phi,
                               atol=1e-6)
    with pytest.raises(ValueError, match='sensor_half_span_rad'):
        BASE.with_changes(sensor_half_span_rad=0.0)


def test_sensor_polynomial_and_fatigue():
    n, dt = 600, 1.0
    da = np.where(np.arange(n) % 40 < 20, 0.5, 0.0)
    db = np.zeros(n)
    p0 = run(BASE, da, db, dt).position_rad
    c2 = run(BASE.with_changes(sensor_c2_rad=0.1), da, db, dt).position_rad
    np.testing.assert_allclose(c2 - p0, 0.1 * p0 ** 2, atol=1e-12)
    c5 = run(BASE.with_changes(sensor_c5_rad=0.05), da, db, dt).position_rad
    np.testing.assert_allclose(c5 - p0, 0.05 * p0 ** 5, atol=1e-12)
    # fatigue: each wire's shakedown g_j = 1 - exp(-N_j/N_f) over its own cycles N_j = sum|dy_j|/2
    da_b = np.where(np.arange(n) % 60 < 20, 0.0, 0.5) * (np.arange(n) > 300)   # b cycles later
    traj = run(BASE, da, da_b, dt)
    ga, gb = (1.0 - np.exp(-0.5 * np.cumsum(np.abs(np.diff(y, prepend=y[0]))) / 4.0)
              for y in (traj.y_a, traj.y_b))
    assert ga[-1] > 0.7 and gb[300] < 1e-9 and gb[-1] > 0.5   # both wires transform, b later
    p1 = traj.position_rad
    drift = run(BASE.with_changes(fatigue_offset_rad=0.2, fatigue_offset_b_rad=-0.1,
                                  fatigue_cycles=4.0), da, da_b, dt)
    np.testing.assert_allclose(drift.position_rad - p1, 0.2 * ga - 0.1 * gb, atol=1e-12)
    shrink = run(BASE.with_changes(fatigue_stroke=0.3, fatigue_cycles=4.0), da, da_b, dt)
    g, s_b = BASE.stroke_rad, BASE.stroke_ratio_b
    np.testing.assert_allclose(shrink.position_rad - p1,
                               -0.3 * g * (traj.y_a * ga - s_b * traj.y_b * gb), atol=1e-12)


def test_potentiometer_round_trip_within_one_lsb():
    pot = Potentiometer(bits=12, angle_min_rad=-1.2, angle_max_rad=1.2)
    phi = np.random.default_rng(3).uniform(-1.2, 1.2, 2000)
    back = np.array([pot.angle(pot.counts(p)) for p in phi])
    assert np.abs(back - phi).max() <= 0.5 * pot.resolution_rad * (1 + 1e-9)
    codes = np.arange(0, pot.full_scale + 1, 37)
    assert [pot.counts(a) for a in pot.angle(codes)] == codes.tolist()
    assert pot.counts(5.0) == pot.full_scale and pot.counts(-5.0) == 0
