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
Fine-grid numba kernel of the rich SMA simulator (see docs/richsim.md for the physics).

One explicit loop over a fine time grid (dt <= 1 ms): command clock (25 ms) -> optional
PI controller -> transport delay -> PWM/current-limit power law -> 1- or 2-node thermal
network (RK4) -> Preisach hysteresis -> fatigue -> antagonistic kinematics -> potentiometer
+ 12-bit ADC.  All effect switches are encoded so that magnitude 0 reproduces the null model.
"""
from collections import namedtuple
import math

from numba import njit
import numpy as np

from .richsim_preisach import preisach_step

# Scalars of the plant, controller and effects (SI units unless the name says otherwise).
PLANT_FIELDS = (
    'supply_v', 'i_max_a', 'pulley_r_m', 'phi0_rad', 'adc_half_range_rad', 'adc_bits',
    'cmd_dt_s', 'kp', 'ki', 'd0', 'u_knee', 'u_max',
    'delay_s', 'tau_fast_s', 'fast_cap_frac',
    'conv_exp', 'conv_ref_k', 'emissivity', 'rho_phase',
    'stress_k_per_stroke', 'stress_self_weight',
    'fatigue_loss', 'fatigue_elong', 'fatigue_n0',
    'cl_knee_duty', 'cl_sharpness',
    'sens_gain', 'sens_sine', 'sens_quad',
    'amb0_c', 'amb_ramp_k_per_s', 'amb_sine_k', 'amb_period_s', 'amb_phase_rad')
Plant = namedtuple('Plant', PLANT_FIELDS)

# Per-wire property columns of the `wires` array, shape (2, N_WIRE_FIELDS).
W_R, W_C, W_HA, W_AREA, W_STROKE, W_LEN, W_FATIGUE = range(7)
N_WIRE_FIELDS = 7
SIGMA_SB = 5.670374419e-8   # Stefan-Boltzmann [W/(m^2 K^4)]


@njit(cache=True)
def ambient(p, t):
    """Return the true ambient [degC], amb0 + ramp*t + sine*sin(2*pi*t/period + phase)."""
    return (p.amb0_c + p.amb_ramp_k_per_s * t
            + p.amb_sine_k * math.sin(2.0 * math.pi * t / p.amb_period_s + p.amb_phase_rad))


@njit(cache=True)
def joule_power(p, wire, duty, xi):
    """
    Mean Joule power [W]: P = d_eff * R(xi) * min(V/R, I_max)^2.

    R(xi) = R_M (1 + rho xi)/(1 + rho)  (R_M: datasheet, martensite; xi: martensite fraction),
    d_eff = k (d/k) / (1 + (d/k)^n)^(1/n): soft average-current limit with knee duty k.
    """
    r = wire[W_R] * (1.0 + p.rho_phase * xi) / (1.0 + p.rho_phase)
    i_pk = min(p.supply_v / r, p.i_max_a)
    d = duty
    if p.cl_knee_duty > 0.0 and d > 0.0:
        x = d / p.cl_knee_duty
        d = p.cl_knee_duty * x / (1.0 + x ** p.cl_sharpness) ** (1.0 / p.cl_sharpness)
    return d * r * i_pk * i_pk


@njit(cache=True)
def heat_loss(p, wire, theta, theta_a):
    """
    Heat lost to air [W]: hA * dT_ref * sign(dT) |dT/dT_ref|^(1+n) + eps sigma A (T^4 - Ta^4).

    n = 0 and eps = 0 give Newton cooling hA (theta - theta_a).
    """
    dt_k = theta - theta_a
    if p.conv_exp == 0.0:
        q = wire[W_HA] * dt_k
    else:
        rel = abs(dt_k / p.conv_ref_k) ** (1.0 + p.conv_exp)
        q = wire[W_HA] * p.conv_ref_k * math.copysign(rel, dt_k)
    if p.emissivity > 0.0:
        t4 = (theta + 273.15) ** 4 - (theta_a + 273.15) ** 4
        q += p.emissivity * SIGMA_SB * wire[W_AREA] * t4
    return q


@njit(cache=True)
def thermal_rhs(p, wire, power, th_heat, th_wire, theta_a):
    """
    d/dt of (heated node, wire node) [K/s].

    One node (tau_fast = 0): C dth/dt = P - Q(th).  Two nodes: C1 dth1/dt = P - G (th1 - th2),
    C2 dth2/dt = G (th1 - th2) - Q(th2), C1 = f C, C2 = (1-f) C, G = C1 / tau_fast, so the
    mean lag of th2 behind P grows by exactly tau_fast (first moment: C/hA + C1/G).
    """
    c = wire[W_C]
    if p.tau_fast_s <= 0.0:
        d = (power - heat_loss(p, wire, th_wire, theta_a)) / c
        return d, d
    c1, c2 = p.fast_cap_frac * c, (1.0 - p.fast_cap_frac) * c
    g = c1 / p.tau_fast_s
    flow = g * (th_heat - th_wire)
    return (power - flow) / c1, (flow - heat_loss(p, wire, th_wire, theta_a)) / c2


@njit(cache=True)
def rk4_thermal(p, wire, power, th1, th2, theta_a, dt):
    """One classical RK4 step of thermal_rhs with power and ambient held over dt."""
    a1, b1 = thermal_rhs(p, wire, power, th1, th2, theta_a)
    a2, b2 = thermal_rhs(p, wire, power, th1 + 0.5 * dt * a1, th2 + 0.5 * dt * b1, theta_a)
    a3, b3 = thermal_rhs(p, wire, power, th1 + 0.5 * dt * a2, th2 + 0.5 * dt * b2, theta_a)
    a4, b4 = thermal_rhs(p, wire, power, th1 + dt * a3, th2 + dt * b3, theta_a)
    return (th1 + dt / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4),
            th2 + dt / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4))


@njit(cache=True)
def sensor_ideal(p, phi):
    """
    Potentiometer reading before noise/ADC [rad].

    y = phi + g FS (s sin(pi x) + q x^2), x = phi/half, FS = 2 half (g = 0: ideal).
    """
    if p.sens_gain == 0.0:
        return phi
    x = phi / p.adc_half_range_rad
    fs = 2.0 * p.adc_half_range_rad
    return phi + p.sens_gain * fs * (p.sens_sine * math.sin(math.pi * x) + p.sens_quad * x * x)


@njit(cache=True)
def adc(p, y):
    """Clip to +-half and quantise: y_q = (code + 1/2) LSB - half, LSB = 2 half / 2^bits."""
    half = p.adc_half_range_rad
    n_codes = 2.0 ** p.adc_bits
    lsb = 2.0 * half / n_codes
    code = min(max(math.floor((y + half) / lsb), 0.0), n_codes - 1.0)
    return (code + 0.5) * lsb - half


@njit(cache=True)
def pi_split(p, err, integ):
    """
    PI + antagonistic split.

     u = kp e + I (clamped to +-u_max, conditional integration); u > 0 heats wire a with d = u + d0
    min(u/u_knee, 1) (dead-zone compensation), u < 0 wire b.
    """
    new_i = integ + p.ki * err * p.cmd_dt_s
    u = p.kp * err + new_i
    if abs(u) > p.u_max and u * err > 0.0:
        new_i = integ                    # anti-windup: freeze the integrator while saturated
        u = p.kp * err + new_i
    u = min(max(u, -p.u_max), p.u_max)
    mag = abs(u)
    d = min(mag + p.d0 * min(mag / p.u_knee, 1.0), p.u_max)
    if u >= 0.0:
        return d, 0.0, new_i
    return 0.0, d, new_i


@njit(cache=True)
def contraction(p, wire, aus, cycles):
    """
    Wire shortening [m]: c = stroke a (1 - loss g) - elong L kappa g, g = 1 - exp(-N/N0).

    a: austenite fraction, N: accumulated transformation cycles (sum |da| / 2).
    """
    if p.fatigue_n0 <= 0.0:
        return wire[W_STROKE] * aus
    g = 1.0 - math.exp(-cycles / p.fatigue_n0)
    return (wire[W_STROKE] * aus * (1.0 - p.fatigue_loss * g)
            - p.fatigue_elong * wire[W_LEN] * wire[W_FATIGUE] * g)


@njit(cache=True)
def stress_shift(p, aus_self, aus_other):
    """
    Upward shift of a wire's transformation temperatures [K] from the loop tension.

    Frictionless pulley: both wires carry the same tension, which grows with the total
    contraction: dT = k (w_self a_self + a_other), k = (tension rise per stroke)/(dsigma/dT).
    """
    return p.stress_k_per_stroke * (p.stress_self_weight * aus_self + aus_other)


@njit(cache=True)
def run(p, wires, tab, lo, step, state, n_steps, dt, stride, closed, cmd_a, cmd_b, setp, noise):
    """
    Simulate n_steps of dt [s]; return per-sample arrays (every `stride` steps).

    Returns out[10, n_samples]: measured position, true angle, wire temperatures a/b,
    austenite fractions a/b, true ambient, mean commanded duty a/b over the following
    sample interval, setpoint.
    """
    n_s = n_steps // stride
    out = np.zeros((10, n_s))
    th = np.empty((2, 2))                 # [wire, node]: node 0 heated, node 1 transforming
    aus = np.zeros(2)
    cycles = np.zeros(2)
    theta_a = ambient(p, 0.0)
    th[:, :] = theta_a
    nd = int(round(p.delay_s / dt))
    ring = np.zeros((2, nd + 1))
    cmd = np.zeros(2)
    integ, last_tick = 0.0, -1
    phi = p.phi0_rad
    for k in range(n_steps):
        t = k * dt
        theta_a = ambient(p, t)
        tick = int(t / p.cmd_dt_s + 1e-9)
        y_meas = 0.0
        if k % stride == 0 or (closed and tick != last_tick):
            y_meas = adc(p, sensor_ideal(p, phi) + noise[k])
        if tick != last_tick:
            if closed:
                cmd[0], cmd[1], integ = pi_split(p, setp[tick] - y_meas, integ)
            else:
                cmd[0], cmd[1] = cmd_a[tick], cmd_b[tick]
            last_tick = tick
        s = k // stride
        if k % stride == 0:
            out[0, s], out[1, s], out[6, s] = y_meas, phi, theta_a
            out[2, s], out[3, s], out[4, s], out[5, s] = th[0, 1], th[1, 1], aus[0], aus[1]
            out[9, s] = setp[tick] if closed else 0.0
        out[7, s] += cmd[0] / stride
        out[8, s] += cmd[1] / stride
        ring[0, k % (nd + 1)], ring[1, k % (nd + 1)] = cmd[0], cmd[1]
        fine_step(p, wires, tab, lo, step, state, th, aus, cycles, ring, k, theta_a, dt)
        phi = shaft_angle(p, wires, aus, cycles)
    return out


@njit(cache=True)
def fine_step(p, wires, tab, lo, step, state, th, aus, cycles, ring, k, theta_a, dt):
    """
    Advance both wires by fine step k in place (th, aus, cycles, Preisach state).

    Each wire gets its command from the delay line `ring` (zero until the delay has
    passed), heats by the PWM/current-limit law, moves its 1/2-node thermal network one
    RK4 step at ambient theta_a and its Preisach fraction at the stress-shifted
    temperature; cycles accumulate |Δa| / 2.
    """
    nd = ring.shape[1] - 1
    a_old0, a_old1 = aus[0], aus[1]
    for w in range(2):
        applied = ring[w, (k - nd) % (nd + 1)] if k >= nd else 0.0
        power = joule_power(p, wires[w], applied, 1.0 - aus[w])
        th[w, 0], th[w, 1] = rk4_thermal(p, wires[w], power, th[w, 0], th[w, 1], theta_a, dt)
        own, other = (a_old0, a_old1) if w == 0 else (a_old1, a_old0)
        u = th[w, 1] - stress_shift(p, own, other)
        aus[w] = preisach_step(state, w, tab, lo, step, u)
    cycles[0] += 0.5 * abs(aus[0] - a_old0)
    cycles[1] += 0.5 * abs(aus[1] - a_old1)


@njit(cache=True)
def shaft_angle(p, wires, aus, cycles):
    """Return the true shaft angle [rad]: φ0 + (c_a − c_b) / 2r (antagonistic pulley)."""
    return p.phi0_rad + (contraction(p, wires[0], aus[0], cycles[0])
                         - contraction(p, wires[1], aus[1], cycles[1])) / (2.0 * p.pulley_r_m)
