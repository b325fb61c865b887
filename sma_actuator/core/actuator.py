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
The antagonistic SMA actuator of the paper's Fig. 14, with switchable physical effects.

Signal chain per wire j in {a, b} (one sample, duty held over dt):

  1. heating  q∞_j = G_j · sat(d_j) · (1 + κ (1 − y_j))             eq. (7) with current limit
              sat(d) = min(d, d_lim) (hard limiter, n = 0) or the smooth p-norm limiter
              d_lim x / (1 + x^n)^(1/n), x = d / d_lim (a limiter with current ripple);
              (G_j = R i_on² / hA, d_lim < 1: average-current limit, κ: resistance of the
              martensite phase, y_j: the wire's contraction fraction, 1 − y_j ≈ martensite)
  2. thermal  θ_j by the exact step (7d)/(7f) with time constant T_j and, with natural
              convection, hA(θ) = hA_ref (|θ − θa| / ΔT_ref)^n (Nusselt ∝ Rayleigh^n, so
              h ∝ ΔT^n; n ≈ 0.06-0.25 for thin wires, more with radiation; ΔT_ref = 50 K),
              i.e. T and G divided by that factor (T, G: the values at 50 K excess)
              ambient θa(t) = θa0 + k_amb (θa_meas(t) − θa0)
  3. hysteresis  y_j = H[θ_j + x − σ y_other]: one modified-PI operator (`PlayHysteresis`)
              shared by both wires, output = contraction fraction (0 cold, 1 hot); σ [K] is
              the stress coupling (Clausius-Clapeyron shift from the antagonist's pull)
  4. shaft    φ = φ0 + g (y_a − s_b y_b)           (pulley kinematics, g = ε L / 2r)
              with functional fatigue of each wire over its own accumulated transformation
              cycles N_j = Σ|Δy_j| / 2: its recoverable stroke shrinks by f_s g_j and its
              plastic elongation moves the zero by f_j g_j, g_j = 1 − exp(−N_j / N_f)
              (shakedown: most of the loss in the first cycles; N_f large: linear drift):
              φ = φ0 + g (y_a (1 − f_s g_a) − s_b y_b (1 − f_s g_b)) + f_a g_a + f_b g_b
  5. sensor   φ_meas(t) = p(φ(t − D)), the potentiometer polynomial
              p(φ) = φ + c2 φ² + c3 φ³ + c4 φ⁴ + c5 φ⁵ (φ in rad).

Steps 1-3 run in one compiled kernel (`simulate_wires`); steps 4-5 are vectorised output
maps. With every effect parameter at its neutral value this is exactly the paper's model
(first-order thermal dynamics, modified PI, linear shaft). The simulated plant node, the
hardware emulator, the controller's thermal guard and the model workbench all call this
module, so there is one implementation of the physics.
"""
from dataclasses import asdict, dataclass, field, fields, replace

from numba import njit
import numpy as np

from .hysteresis import PlayHysteresis
from .thermal import on_current_a, thermal_step, time_constant_s
from .validate import finite_array, finite_scalar

# ----------------------------------------------------------------------------------------
# Flexinol 150 um LT, 250 mm defaults (Dynalloy Flexinol technical data):
#   resistance 55 ohm/m, recommended current ~250 mA (1 s contraction), transformation
#   temperatures of the LT (70 °C) alloy: As ~68, Af ~78, Ms ~52, Mf ~42 °C,
#   relaxation (cooling) ~2 s in still air, usable strain 3-5 % (4 % used),
#   density 6450 kg/m3, specific heat 0.2 cal/(g °C) = 837 J/(kg K).
# Derived: R = 13.75 ohm, m = 2.85e-5 kg, C = 0.0239 J/K; T = 2.0 s (cooling Af -> Mf at
# 22 °C ambient takes T ln(56/20) ~ 2.1 s), hA = C/T = 0.0119 W/K; supply 5 V with a
# 0.35 A current limiter gives i_on = 0.35 A, P_on = 1.68 W, G = P_on/hA ~ 141 K.
# Shaft: pulley radius 5 mm, so 4 % of 250 mm = 10 mm of stroke per wire = 2 rad of
# differential travel: g = 1 rad per unit contraction difference, range about ±1 rad.
# ----------------------------------------------------------------------------------------


def flexinol_hysteresis(n_widths=4, n_centres=4):
    """
    Return the default modified-PI hysteresis, temperature [°C] -> contraction fraction [0, 1].

    Built from the datasheet transformation temperatures: play half-widths spread around
    half the loop width ((As + Af)/2 − (Ms + Mf)/2)/2 = 13 K and saturated elements centred
    between the branches so that heating completes between As and Af and cooling between
    Ms and Mf (a 4 x 4 grid, equal weights summing to 1). Minor loops then follow from the
    spread of widths, as the paper's Fig. 9/11 show.
    """
    a_s, a_f, m_s, m_f = 68.0, 78.0, 52.0, 42.0
    mid = 0.25 * (a_s + a_f + m_s + m_f)          # 60 °C: centre of the loop
    half_width = 0.25 * ((a_s + a_f) - (m_s + m_f))  # 13 K
    widths = half_width * np.linspace(0.85, 1.15, n_widths)
    spread = 0.5 * (a_f - a_s)                    # each branch spans ±5 K around its centre
    centres = mid + np.linspace(-0.4, 0.4, n_centres) * spread
    r, c = np.meshgrid(widths, centres, indexing='ij')
    r, c = r.ravel(), c.ravel()
    band = 0.45 * spread
    n = r.size
    return PlayHysteresis(r, c - band, c + band, np.full(n, 1.0 / (2 * band * n)), 0.0,
                          -float(np.sum((c - band) / (2 * band * n))))


@dataclass
class ActuatorParams:
    """
    Physical parameters of the antagonistic actuator and its switchable effects.

    Every effect parameter's default is its neutral value (effect off), except
    ambient_gain = 1: a simulated wire feels the ambient it is given.
    """

    # wire and amplifier (Flexinol 150 um LT, 250 mm; see module comment for sources)
    length_m: float = 0.25
    resistance_ohm_per_m: float = 55.0
    supply_v: float = 5.0
    current_limit_a: float = 0.35
    heat_capacity_j_per_k: float = 0.0239
    conductance_w_per_k: float = 0.01195
    ambient_c: float = 22.0
    # shaft and sensor
    stroke_rad: float = 1.0          # g: shaft angle per unit contraction-fraction difference
    offset_rad: float = 0.0          # φ0
    # effects (neutral values = off)
    tau_fast_s: float = 0.0          # fast_dynamics: lag on the heat input [s]
    delay_s: float = 0.0             # delay: transport delay of the measured position [s]
    convection_exponent: float = 0.0  # convection: hA(θ) = hA_ref (|θ − θa| / 50 K)^n
    # ambient_drift: weight of measured ambient deviations (1 = physical; the workbench base
    # model uses 0)
    ambient_gain: float = 1.0
    phase_kappa: float = 0.0         # phase_resistance: power factor 1 + κ (1 − y)
    stress_k: float = 0.0            # stress_coupling: shift [K] per unit antagonist contraction
    gain_ratio_b: float = 1.0        # asymmetric_wires: heating gain of wire b relative to a
    tau_ratio_b: float = 1.0         # asymmetric_wires: time constant of wire b relative to a
    stroke_ratio_b: float = 1.0      # asymmetric_wires: stroke of wire b relative to a
    sensor_c2_rad: float = 0.0       # sensor_nonlinearity: quadratic term [rad at 1 rad]
    sensor_c3_rad: float = 0.0       # sensor_nonlinearity: cubic term [rad at 1 rad]
    sensor_c4_rad: float = 0.0       # sensor_nonlinearity: 4th-order term [rad at 1 rad]
    sensor_c5_rad: float = 0.0       # sensor_nonlinearity: 5th-order term [rad at 1 rad]
    fatigue_offset_rad: float = 0.0  # fatigue_drift: zero drift from wire a after shakedown [rad]
    fatigue_offset_b_rad: float = 0.0  # fatigue_drift: zero drift from wire b [rad]
    fatigue_stroke: float = 0.0      # fatigue_drift: stroke loss fraction after shakedown
    fatigue_cycles: float = 20.0     # fatigue_drift: shakedown constant N_f [cycles of a wire]
    duty_limit: float = 1.0          # current_limit: duty above which mean current saturates
    duty_limit_sharpness: float = 0.0  # current_limit: p-norm sharpness n (0 = hard min)
    hysteresis: PlayHysteresis = field(default_factory=flexinol_hysteresis)

    def __post_init__(self):
        for f in fields(self):
            if f.name != 'hysteresis':
                setattr(self, f.name, finite_scalar(f.name, getattr(self, f.name)))
        for name in ('length_m', 'resistance_ohm_per_m', 'supply_v', 'current_limit_a',
                     'heat_capacity_j_per_k', 'conductance_w_per_k', 'tau_ratio_b',
                     'fatigue_cycles'):
            if getattr(self, name) <= 0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name)}')
        for name in ('tau_fast_s', 'delay_s', 'gain_ratio_b', 'stroke_ratio_b',
                     'duty_limit_sharpness'):
            if getattr(self, name) < 0:
                raise ValueError(f'{name} must be non-negative, got {getattr(self, name)}')
        if not 0.0 < self.duty_limit <= 1.0:
            raise ValueError(f'duty_limit must be in (0, 1], got {self.duty_limit}')

    @property
    def resistance_ohm(self):
        """Wire resistance R [ohm]."""
        return self.resistance_ohm_per_m * self.length_m

    @property
    def tau_s(self):
        """Return the basic thermal time constant T = C / hA [s] (Fig. 13)."""
        return time_constant_s(self.heat_capacity_j_per_k, self.conductance_w_per_k)

    @property
    def gain_k(self):
        """Steady temperature rise at full duty G = R i_on² / hA [K]."""
        i_on = on_current_a(self.supply_v, self.resistance_ohm, self.current_limit_a)
        return self.resistance_ohm * i_on ** 2 / self.conductance_w_per_k

    def kernel_vector(self):
        """Parameter vector of `simulate_wires` (see KERNEL_PARAMS for the order)."""
        return np.array([self.tau_s, self.gain_k, self.ambient_c, self.tau_fast_s,
                         self.convection_exponent, self.ambient_gain, self.phase_kappa,
                         self.stress_k, self.gain_ratio_b, self.tau_ratio_b, self.duty_limit,
                         self.duty_limit_sharpness])

    def with_changes(self, **changes):
        """Return a copy with some fields changed (validated)."""
        return replace(self, **changes)

    def to_dict(self):
        """Plain-data form (YAML model files)."""
        d = asdict(self)
        d['hysteresis'] = self.hysteresis.to_dict()
        return d

    @classmethod
    def from_dict(cls, d):
        """Inverse of `to_dict`; unknown keys raise."""
        d = dict(d)
        known = {f.name for f in fields(cls)}
        unknown = set(d) - known
        if unknown:
            raise ValueError(f'unknown actuator parameter(s): {sorted(unknown)}')
        if 'hysteresis' in d and not isinstance(d['hysteresis'], PlayHysteresis):
            d['hysteresis'] = PlayHysteresis.from_dict(d['hysteresis'])
        return cls(**d)


# reference excess temperature of the convection law [K]: T and G are the values there
CONVECTION_REF_K = 50.0
KERNEL_PARAMS = ('tau_s', 'gain_k', 'ambient_c', 'tau_fast_s', 'convection_exponent',
                 'ambient_gain', 'phase_kappa', 'stress_k', 'gain_ratio_b', 'tau_ratio_b',
                 'duty_limit', 'duty_limit_sharpness')


@njit(cache=True)
def simulate_wires(duty_a, duty_b, ambient, disturbance, dt, p, r, lo, hi, w, k1, y0, state,
                   feat_a, feat_b, u_a, u_b, feat_start, feat_step):
    """
    Step 1-3 of the module docstring for n samples; returns (y_a, y_b, θ_a, θ_b).

    duty_*, ambient [°C], disturbance [K]: length-n inputs, sample k held over
    [t_k, t_k + dt). Outputs follow the sampled-data convention: sample k is the state at
    t_k, before duty k acts (a measurement taken when the command is sent).
    p: `ActuatorParams.kernel_vector()`; r, lo, hi, w, k1, y0: the shared hysteresis.
    state (updated in place, ends at t_n): [θ_a, θ_b, q_a, q_b, y_a, y_b, s_a (N), s_b (N),
    u_a, u_b] with u the hysteresis inputs.
    feat_a/feat_b (R, N) and u_a/u_b (R,): when R > 0, filled with the element states and
    hysteresis inputs at samples feat_start + i feat_step, i < R (the regressors of
    identification, recorded only at the regression rows: the full-rate arrays would be
    mostly thrown away); ignored when R = 0.
    """
    n = duty_a.shape[0]
    m = r.shape[0]
    tau, gain, amb0, tau_f, conv_n, k_amb, kappa, sigma, g_b, t_b, d_lim, sharp = (
        p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11])
    out_ya = np.empty(n)
    out_yb = np.empty(n)
    out_ta = np.empty(n)
    out_tb = np.empty(n)
    n_rows = feat_a.shape[0]
    iu = 6 + 2 * m
    for k in range(n):
        # record the state at t_k
        out_ta[k], out_tb[k], out_ya[k], out_yb[k] = state[0], state[1], state[4], state[5]
        row = (k - feat_start) // feat_step
        if k >= feat_start and row < n_rows and (k - feat_start) % feat_step == 0:
            for i in range(m):
                feat_a[row, i] = state[6 + i]
                feat_b[row, i] = state[6 + m + i]
            u_a[row] = state[iu]
            u_b[row] = state[iu + 1]
        # advance to t_k + dt
        th_amb = amb0 + k_amb * (ambient[k] - amb0)
        y_prev_a = state[4]
        y_prev_b = state[5]
        for j in range(2):
            d = duty_a[k] if j == 0 else duty_b[k]
            d = max(d, 0.0)
            if sharp > 0.0:
                x = d / d_lim
                d = d_lim * x / (1.0 + x ** sharp) ** (1.0 / sharp)
            else:
                d = min(d, d_lim)
            y_own = y_prev_a if j == 0 else y_prev_b
            y_other = y_prev_b if j == 0 else y_prev_a
            g = gain if j == 0 else gain * g_b
            t = tau if j == 0 else tau * t_b
            theta = state[j]
            if conv_n != 0.0:   # hA(θ) / hA_ref; below 0.5 K excess the law is held constant
                f = max((max(abs(theta - th_amb), 0.5) / CONVECTION_REF_K) ** conv_n, 0.05)
                g = g / f
                t = t / f
            q_inf = g * d * (1.0 + kappa * (1.0 - y_own))
            theta, q = thermal_step(theta, state[2 + j], th_amb, q_inf, dt, t, tau_f)
            state[j] = theta
            state[2 + j] = q
            u = theta + disturbance[k] - sigma * y_other
            state[iu + j] = u
            acc = y0 + k1 * u
            base = 6 + j * m
            for i in range(m):
                v = min(max(state[base + i], u - r[i]), u + r[i])
                v = min(max(v, lo[i]), hi[i])
                state[base + i] = v
                acc += w[i] * v
            state[4 + j] = acc
    return out_ya, out_yb, out_ta, out_tb


NO_FEATURES = (np.zeros((0, 0)), np.zeros((0, 0)), np.zeros(0), np.zeros(0), 0, 1)


def initial_state(params, theta_c=None):
    """Kernel state at rest: both wires at ambient (or theta_c), cold branch of the hysteresis."""
    h = params.hysteresis
    theta = params.ambient_c if theta_c is None else finite_scalar('theta_c', theta_c)
    s = h.initial_state(theta)
    y = h.y0 + h.k1 * theta + float(h.w @ s)
    return np.concatenate([[theta, theta, 0.0, 0.0, y, y], s, s, [theta, theta]])


def shaft_angle(params, y_a, y_b, cycles_a=None, cycles_b=None):
    """
    Step 4.

    φ = φ0 + g (y_a (1 − f_s g_a) − s_b y_b (1 − f_s g_b)) + f_a g_a + f_b g_b [rad], g_j = g(N_j)
    the fatigue shakedown of wire j after N_j cycles (none if cycles are None).
    """
    y_a, y_b = np.asarray(y_a, float), np.asarray(y_b, float)
    if cycles_a is None:
        return params.offset_rad + params.stroke_rad * (y_a - params.stroke_ratio_b * y_b)
    g_a, g_b = fatigue_progress(params, cycles_a), fatigue_progress(params, cycles_b)
    loss = params.fatigue_stroke
    return (params.offset_rad + params.stroke_rad * (
        y_a * (1.0 - loss * g_a) - params.stroke_ratio_b * y_b * (1.0 - loss * g_b))
        + params.fatigue_offset_rad * g_a + params.fatigue_offset_b_rad * g_b)


def transformation_cycles(y, n0=0.0):
    """
    Return the accumulated transformation cycles of one wire, N = n0 + Σ|Δy| / 2 per sample.

    A full contraction and release counts 1.
    """
    y = np.asarray(y, float)
    return n0 + 0.5 * np.cumsum(np.abs(np.diff(y, prepend=y[0])))


def fatigue_progress(params, cycles):
    """Shakedown fraction g(N) = 1 − exp(−N / N_f) of functional fatigue."""
    return -np.expm1(-np.asarray(cycles) / params.fatigue_cycles)


def sensor_polynomial(params, phi):
    """
    Return the potentiometer reading, step 5 without the delay.

    p(φ) = φ + c2 φ² + c3 φ³ + c4 φ⁴ + c5 φ⁵ [rad].
    """
    return phi + phi * phi * (params.sensor_c2_rad + phi * (params.sensor_c3_rad + phi * (
        params.sensor_c4_rad + phi * params.sensor_c5_rad)))


def sensor_inverse(params, reading, n_grid=8193):
    """
    Angle φ with p(φ) = reading, `sensor_polynomial` inverted [rad].

    p is evaluated on a dense grid over the readings' span widened by that span each
    side, and inverted by interpolation on its rising branch through the middle of the
    readings. Where that branch does not reach every reading (the bounds allow p to turn
    far from the travel), the first-order inverse 2y − p(y), exact to O(c²), is returned.
    """
    y = np.asarray(reading, float)
    if not (params.sensor_c2_rad or params.sensor_c3_rad or params.sensor_c4_rad
            or params.sensor_c5_rad):
        return y
    lo, hi = float(np.min(y)), float(np.max(y))
    span = max(hi - lo, 1e-3)
    phi = np.linspace(lo - span, hi + span, n_grid)
    p = sensor_polynomial(params, phi)
    falls = np.flatnonzero(np.diff(p) <= 0)        # p[i + 1] <= p[i]
    mid = n_grid // 2
    a = int(falls[falls < mid].max()) + 1 if np.any(falls < mid) else 0
    b = int(falls[falls >= mid].min()) if np.any(falls >= mid) else n_grid - 1
    if p[a] <= lo and p[b] >= hi:
        return np.interp(y, p[a:b + 1], phi[a:b + 1])
    return 2.0 * y - sensor_polynomial(params, y)


def delay_signal(x, dt, delay_s):
    """x(t − D) on the sample grid, linear interpolation, holding the first value before t0."""
    if delay_s <= 0:
        return x
    t = np.arange(len(x)) * dt
    return np.interp(t - delay_s, t, x, left=x[0])


@dataclass
class Trajectory:
    """Batch simulation result (arrays of length n)."""

    position_rad: np.ndarray
    theta_a_c: np.ndarray
    theta_b_c: np.ndarray
    y_a: np.ndarray
    y_b: np.ndarray


def simulate(params, duty_a, duty_b, dt, ambient_c=None, disturbance_k=None, state=None):
    """
    Free-run simulation of the whole actuator (steps 1-5) for duty sequences at step dt [s].

    ambient_c: measured ambient [°C] per sample (defaults to params.ambient_c);
    disturbance_k: temperature disturbance x of Fig. 13 [K]. Returns a `Trajectory`.
    """
    duty_a = finite_array('duty_a', duty_a)
    duty_b = finite_array('duty_b', duty_b)
    n = len(duty_a)
    if len(duty_b) != n:
        raise ValueError(f'duty_a and duty_b differ in length ({n} vs {len(duty_b)})')
    if (duty_a < 0).any() or (duty_a > 1).any() or (duty_b < 0).any() or (duty_b > 1).any():
        raise ValueError('duty_a/duty_b must lie in [0, 1]')
    dt = finite_scalar('dt', dt)
    if dt <= 0:
        raise ValueError(f'dt must be positive, got {dt}')
    amb = (np.full(n, params.ambient_c) if ambient_c is None
           else finite_array('ambient_c', np.broadcast_to(ambient_c, (n,))))
    dist = (np.zeros(n) if disturbance_k is None
            else finite_array('disturbance_k', np.broadcast_to(disturbance_k, (n,))))
    h = params.hysteresis
    st = initial_state(params) if state is None else state
    ya, yb, ta, tb = simulate_wires(duty_a, duty_b, amb, dist, dt, params.kernel_vector(),
                                    h.r, h.lo, h.hi, h.w, h.k1, h.y0, st, *NO_FEATURES)
    phi = shaft_angle(params, ya, yb, transformation_cycles(ya), transformation_cycles(yb))
    phi = sensor_polynomial(params, phi)
    return Trajectory(delay_signal(phi, dt, params.delay_s), ta, tb, ya, yb)


class AntagonisticActuator:
    """
    Streaming form of `simulate` for nodes: `step(duty_a, duty_b, dt)` -> shaft angle [rad].

    Long steps are split into sub-steps of at most `max_substep_s` so the feedback effects
    (phase resistance, stress coupling, convection) stay accurate at any call rate.
    """

    def __init__(self, params=None, max_substep_s=0.005):
        self.params = ActuatorParams() if params is None else params
        self.max_substep_s = float(max_substep_s)
        self.reset()

    def reset(self, theta_c=None):
        """Both wires at ambient (or theta_c), cold and fully martensitic, shaft at rest."""
        self._state = initial_state(self.params, theta_c)
        self._time = 0.0
        self._cycles = np.zeros(2)         # per wire
        self._history = [(0.0, self._measured(self._state[4], self._state[5]))]

    @property
    def temperature_c(self):
        """Wire temperatures [θ_a, θ_b] in °C."""
        return self._state[:2].copy()

    @property
    def contraction(self):
        """Contraction fractions [y_a, y_b] (0 cold, 1 fully contracted)."""
        return self._state[4:6].copy()

    @property
    def reading_now(self):
        """Sensed shaft angle [rad] at the present time, before the transport delay."""
        return self._history[-1][1]

    def _measured(self, y_a, y_b):
        phi = shaft_angle(self.params, y_a, y_b, self._cycles[0], self._cycles[1])
        return float(sensor_polynomial(self.params, phi))

    def step(self, duty_a, duty_b, dt, ambient_c=None, disturbance_k=0.0):
        """Hold the duties for dt seconds; return the (delayed, sensed) shaft angle [rad]."""
        for name, d in (('duty_a', duty_a), ('duty_b', duty_b)):
            d = finite_scalar(name, d)
            if not 0.0 <= d <= 1.0:
                raise ValueError(f'{name} must be in [0, 1], got {d}')
        dt = finite_scalar('dt', dt)
        if dt <= 0:
            raise ValueError(f'dt must be positive, got {dt}')
        amb = self.params.ambient_c if ambient_c is None else finite_scalar('ambient_c', ambient_c)
        dist = finite_scalar('disturbance_k', disturbance_k)
        n_sub = max(1, int(np.ceil(dt / self.max_substep_s)))
        h = self.params.hysteresis
        y_before = self._state[4:6].copy()
        simulate_wires(np.full(n_sub, float(duty_a)), np.full(n_sub, float(duty_b)),
                       np.full(n_sub, amb), np.full(n_sub, dist), dt / n_sub,
                       self.params.kernel_vector(), h.r, h.lo, h.hi, h.w, h.k1,
                       h.y0, self._state, *NO_FEATURES)
        self._cycles += 0.5 * np.abs(self._state[4:6] - y_before)
        self._time += dt
        self._history.append((self._time, self._measured(self._state[4], self._state[5])))
        return self._delayed()

    def _delayed(self):
        delay = self.params.delay_s
        t_query = self._time - delay
        # drop history older than needed, keep one sample before t_query for interpolation
        while len(self._history) > 2 and self._history[1][0] <= t_query:
            self._history.pop(0)
        if delay <= 0:
            return self._history[-1][1]
        times, values = zip(*self._history)
        return float(np.interp(t_query, times, values))
