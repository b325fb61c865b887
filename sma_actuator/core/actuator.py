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
              the stress coupling (Clausius-Clapeyron shift from the antagonist's pull);
              latent heat: θ_j = θ_j,pred − λ Δy_j over the sample, solved implicitly
              with y_j = H[θ_j ...] at the sample's end (C dθ/dt = ... − L dξ/dt,
              λ = L / C >= 0 per unit contraction: heating stalls while the wire
              transforms, cooling is held up by the heat the reverse transformation gives
              back)
  4. shaft    φ = φ0 + g (y_a − s_b y_b)           (pulley kinematics, g = ε L / 2r)
              with functional fatigue of each wire over its own accumulated transformation
              cycles N_j = Σ|Δy_j| / 2: its recoverable stroke shrinks by f_s g_j and its
              plastic elongation moves the zero by f_j g_j, g_j = 1 − exp(−N_j / N_f)
              (shakedown: most of the loss in the first cycles; N_f large: linear drift):
              φ = φ0 + g (y_a (1 − f_s g_a) − s_b y_b (1 − f_s g_b)) + f_a g_a + f_b g_b
  5. sensor   φ_meas(t) = p(φ(t − D)), the potentiometer polynomial
              p(φ) = φ + h (c2 x² + c3 x³ + c4 x⁴ + c5 x⁵) in the scaled travel
              x = (φ − φc) / h (φc: centre of travel, h: half travel; 0 and 1 rad by default).

Steps 1-3 run in one compiled kernel (`simulate_wires`); steps 4-5 are vectorised output
maps. With every effect parameter at its neutral value this is exactly the paper's model
(first-order thermal dynamics, modified PI, linear shaft). The simulated plant node, the
hardware emulator, the controller's thermal guard and the model workbench all call this
module, so there is one implementation of the physics.
"""
from collections import namedtuple
from dataclasses import asdict, dataclass, field, fields, replace
import math
from operator import attrgetter
from typing import Any, Dict, Optional, Tuple

from numba import njit
import numpy as np
from numpy.typing import ArrayLike

from .hysteresis import PlayHysteresis
from .kernels import kernel_array
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


def flexinol_hysteresis(n_widths: int = 4, n_centres: int = 4) -> PlayHysteresis:
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


# excess temperature at which T and G are given when the convection law is on [K]
CONVECTION_REF_K = 50.0
# ambient temperatures the nodes accept, measured or nominal [°C]: a reading outside is a
# broken sensor, not weather
AMBIENT_RANGE_C = (-40.0, 80.0)

# identification roles (`ParamSpec.role`): 'feedback' parameters feed the hysteresis output
# back into its own regressors; 'linear' ones are solved with the weights (no outer
# search) and are feedback parameters as well
FEEDBACK = 'feedback'
LINEAR = 'linear'
ROLES = (FEEDBACK, LINEAR)


@dataclass(frozen=True)
class ParamSpec:
    """
    Declaration of one physical parameter: everything the package derives from it.

    unit and description (what `plant_sim` and the docs show), neutral: the value at which
    its effect is off (the ablation value of a plug-in parameter); effect: the catalog
    effect that frees it (None: a base-model parameter); plant: the plant node's accepted
    range (None: not a plant parameter); fit: the workbench's (lower, upper, start) when
    its effect is fitted; fit_stand_in: (plant value outside the fit bounds, the fit value
    that represents it); role: FEEDBACK, LINEAR or None (`core.identification`);
    kernel: read by the compiled kernel (its slot is its place in `KERNEL_PARAMS`).
    """

    unit: str
    description: str
    neutral: Optional[float] = None
    effect: Optional[str] = None
    plant: Optional[Tuple[float, float]] = None
    fit: Optional[Tuple[float, float, float]] = None
    fit_stand_in: Optional[Tuple[float, float]] = None
    role: Optional[str] = None
    kernel: bool = False

    def __post_init__(self) -> None:
        if self.role not in (None,) + ROLES:
            raise ValueError(f'role must be one of {ROLES} or None, got {self.role!r}')
        if self.fit is not None and not self.fit[0] <= self.fit[2] <= self.fit[1]:
            raise ValueError(f'fit start {self.fit[2]} outside its bounds {self.fit[:2]}')

    @property
    def label(self) -> str:
        """Return the description with its unit, as a person reads it."""
        return f'{self.description} [{self.unit}]' if self.unit else self.description

    def fit_covers(self, value: float) -> bool:
        """Return True if the fit can represent plant value `value` (bounds or stand-in)."""
        if self.fit_stand_in is not None and value == self.fit_stand_in[0]:
            value = self.fit_stand_in[1]
        return self.fit is not None and self.fit[0] <= value <= self.fit[1]


SPEC = 'spec'   # the dataclass field metadata key of a ParamSpec


def declare(default: float, unit: str, description: str, **spec: Any) -> Any:
    """
    Return a dataclass field of `ActuatorParams` with its `ParamSpec`.

    The neutral value defaults to `default` (an effect is off at its default, except
    where `neutral` says otherwise).
    """
    spec.setdefault('neutral', default)
    return field(default=default, metadata={SPEC: ParamSpec(unit, description, **spec)})


@dataclass
class ActuatorParams:
    """
    Physical parameters of the antagonistic actuator and its switchable effects.

    Every parameter is declared here once, with its `ParamSpec`; the kernel vector, the
    plant node's parameters, the catalog effects' fit tables and identification's role
    sets derive from these declarations (docs/architecture.md). Every effect parameter's
    default is its neutral value (effect off), except ambient_gain = 1: a simulated wire
    feels the ambient it is given.
    """

    # wire and amplifier (Flexinol 150 um LT, 250 mm; see module comment for sources)
    length_m: float = declare(0.25, 'm', 'wire length')
    resistance_ohm_per_m: float = declare(55.0, 'ohm/m', 'wire resistance per length')
    supply_v: float = declare(5.0, 'V', 'amplifier supply voltage')
    current_limit_a: float = declare(0.35, 'A', 'amplifier current limit')
    heat_capacity_j_per_k: float = declare(0.0239, 'J/K', 'heat capacity C of one wire')
    conductance_w_per_k: float = declare(0.01195, 'W/K', 'heat transfer hA of one wire')
    ambient_c: float = declare(22.0, '°C', 'nominal ambient temperature', kernel=True)
    # shaft and sensor
    stroke_rad: float = declare(1.0, 'rad',
                                'g: shaft angle per unit contraction-fraction difference')
    offset_rad: float = declare(0.0, 'rad', 'φ0: shaft angle with both wires cold')
    # effects (neutral values = off)
    tau_fast_s: float = declare(
        0.0, 's', 'fast dynamics: lag on the heat input (Fig. 13 tau)', effect='fast_dynamics',
        plant=(0.0, 2.0), fit=(0.0, 3.0, 0.15), kernel=True)
    delay_s: float = declare(
        0.0, 's', 'transport delay of the measured position', effect='delay',
        plant=(0.0, 1.0), fit=(0.0, 1.5, 0.05))
    convection_exponent: float = declare(
        0.0, '', 'convection: hA(θ) = hA_ref (|θ − θa| / 50 K)^n', effect='convection',
        plant=(0.0, 1.0), fit=(-0.2, 1.0, 0.2), kernel=True)
    # 1 is physical; the workbench base model uses the neutral 0 (constant ambient)
    ambient_gain: float = declare(
        1.0, '', 'weight of measured ambient deviations', neutral=0.0, effect='ambient_drift',
        plant=(0.0, 2.0), fit=(0.0, 3.0, 1.0), kernel=True)
    # NiTi resistivity differs by roughly 10-25 % between the phases; the fit bound leaves
    # room for a current limiter that is not perfectly stiff
    phase_kappa: float = declare(
        0.0, '', 'phase resistance: heating factor 1 + κ (1 − y)', effect='phase_resistance',
        plant=(-0.5, 0.5), fit=(-0.5, 0.5, 0.1), role=FEEDBACK, kernel=True)
    # NiTi absorbs ~20 J/g on heating through the transformation and gives it back on
    # cooling; with c ~ 0.84 J/(g K) that holds the wire ~25 K below the heat balance's
    # temperature for a full transformation
    latent_heat_k: float = declare(
        0.0, 'K', 'latent heat: temperature drop per unit contraction', effect='latent_heat',
        plant=(0.0, 40.0), fit=(0.0, 40.0, 1.0), role=FEEDBACK, kernel=True)
    stress_k: float = declare(
        0.0, 'K', 'stress coupling: shift per unit antagonist contraction',
        effect='stress_coupling', plant=(0.0, 50.0), fit=(0.0, 50.0, 4.0), role=FEEDBACK,
        kernel=True)
    gain_ratio_b: float = declare(
        1.0, '', 'asymmetric wires: heating gain of wire b relative to a',
        effect='asymmetric_wires', plant=(0.5, 2.0), fit=(0.5, 2.0, 1.0), kernel=True)
    tau_ratio_b: float = declare(
        1.0, '', 'asymmetric wires: time constant of wire b relative to a',
        effect='asymmetric_wires', plant=(0.5, 2.0), fit=(0.5, 2.0, 1.0), kernel=True)
    stroke_ratio_b: float = declare(
        1.0, '', 'asymmetric wires: stroke of wire b relative to a',
        effect='asymmetric_wires', plant=(0.5, 2.0), fit=(0.5, 2.0, 1.0))
    # the polynomial runs in x = (φ − φc) / h, the travel scaled to about ±1, so its terms mean
    # the same on any rig and in any position unit; the workbench sets φc and h from the
    # measured travel when it fits the terms, and the neutral φc = 0, h = 1 make x = φ [rad]
    sensor_centre_rad: float = declare(
        0.0, 'rad', 'potentiometer polynomial: centre of travel φc it is expanded about')
    sensor_half_span_rad: float = declare(
        1.0, 'rad', 'potentiometer polynomial: half travel h its terms are scaled by')
    # fit bounds: each term alone keeps p monotone over about x = ±1 (together they may turn
    # earlier: `sensor_inverse` then falls back to first order)
    sensor_c2_rad: float = declare(
        0.0, '× h at x = 1', 'potentiometer quadratic term', effect='sensor_nonlinearity',
        plant=(-0.2, 0.2), fit=(-0.25, 0.25, 0.0))
    sensor_c3_rad: float = declare(
        0.0, '× h at x = 1', 'potentiometer cubic term', effect='sensor_nonlinearity',
        plant=(-0.2, 0.2), fit=(-0.3, 0.3, 0.0))
    sensor_c4_rad: float = declare(
        0.0, '× h at x = 1', 'potentiometer 4th-order term', effect='sensor_nonlinearity',
        plant=(-0.15, 0.15), fit=(-0.15, 0.15, 0.0))
    sensor_c5_rad: float = declare(
        0.0, '× h at x = 1', 'potentiometer 5th-order term', effect='sensor_nonlinearity',
        plant=(-0.15, 0.15), fit=(-0.15, 0.15, 0.0))
    # the zero drifts are solved linearly with the weights, each within ± half the measured
    # travel (`core.identification`), so their fit bounds are open
    fatigue_offset_rad: float = declare(
        0.0, 'rad', 'fatigue: zero drift from wire a after shakedown', effect='fatigue_drift',
        plant=(-0.3, 0.3), fit=(-math.inf, math.inf, 0.0), role=LINEAR)
    fatigue_offset_b_rad: float = declare(
        0.0, 'rad', 'fatigue: zero drift from wire b after shakedown', effect='fatigue_drift',
        plant=(-0.3, 0.3), fit=(-math.inf, math.inf, 0.0), role=LINEAR)
    fatigue_stroke: float = declare(
        0.0, '', 'fatigue: stroke loss fraction after shakedown', effect='fatigue_drift',
        plant=(0.0, 0.5), fit=(-0.5, 0.8, 0.05), role=FEEDBACK)
    # N_f >= 2 cycles in the fit: a faster shakedown ends within the first transformation,
    # where g_a − g_b with huge cancelling offsets only fits the start-up transient
    fatigue_cycles: float = declare(
        20.0, 'cycles of one wire', 'fatigue: shakedown constant N_f', effect='fatigue_drift',
        plant=(2.0, 5000.0), fit=(2.0, 5000.0, 20.0), role=FEEDBACK)
    duty_limit: float = declare(
        1.0, '', 'current limit: duty above which the mean current saturates',
        effect='current_limit', plant=(0.05, 1.0), fit=(0.02, 1.0, 0.9), kernel=True)
    # the fit's sharpness n runs from ~2 (very soft) to 30 (practically a hard corner),
    # which stands in for the plant's 0 (a hard min, n -> inf)
    duty_limit_sharpness: float = declare(
        0.0, '', 'current limit: p-norm sharpness (0 = hard corner)', effect='current_limit',
        plant=(0.0, 30.0), fit=(2.0, 30.0, 6.0), fit_stand_in=(0.0, 30.0), kernel=True)
    hysteresis: PlayHysteresis = field(default_factory=flexinol_hysteresis)

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name != 'hysteresis':
                setattr(self, f.name, finite_scalar(f.name, getattr(self, f.name)))
        for name in ('length_m', 'resistance_ohm_per_m', 'supply_v', 'current_limit_a',
                     'heat_capacity_j_per_k', 'conductance_w_per_k', 'tau_ratio_b',
                     'fatigue_cycles', 'sensor_half_span_rad'):
            if getattr(self, name) <= 0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name)}')
        for name in ('tau_fast_s', 'delay_s', 'gain_ratio_b', 'stroke_ratio_b',
                     'duty_limit_sharpness', 'latent_heat_k'):
            if getattr(self, name) < 0:
                raise ValueError(f'{name} must be non-negative, got {getattr(self, name)}')
        if not 0.0 < self.duty_limit <= 1.0:
            raise ValueError(f'duty_limit must be in (0, 1], got {self.duty_limit}')

    @property
    def resistance_ohm(self) -> float:
        """Return the wire resistance R [ohm]."""
        return self.resistance_ohm_per_m * self.length_m

    @property
    def tau_s(self) -> float:
        """Return the basic thermal time constant T = C / hA [s] (Fig. 13)."""
        return time_constant_s(self.heat_capacity_j_per_k, self.conductance_w_per_k)

    @property
    def gain_k(self) -> float:
        """Return the steady temperature rise at full duty G = R i_on² / hA [K]."""
        i_on = on_current_a(self.supply_v, self.resistance_ohm, self.current_limit_a)
        return self.resistance_ohm * i_on ** 2 / self.conductance_w_per_k

    def kernel_vector(self) -> np.ndarray:
        """Return the parameter vector of `simulate_wires`: `KERNEL_PARAMS` in `SLOT` order."""
        return np.array(_kernel_values(self))

    def with_changes(self, **changes: Any) -> 'ActuatorParams':
        """Return a copy with some fields changed (validated)."""
        return replace(self, **changes)

    def to_dict(self) -> Dict[str, Any]:
        """Return the plain-data form (YAML model files)."""
        d = asdict(self)
        d['hysteresis'] = self.hysteresis.to_dict()
        return d

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> 'ActuatorParams':
        """Return the inverse of `to_dict`; unknown keys raise."""
        d = dict(d)
        known = {f.name for f in fields(cls)}
        unknown = set(d) - known
        if unknown:
            raise ValueError(f'unknown actuator parameter(s): {sorted(unknown)}')
        if 'hysteresis' in d and not isinstance(d['hysteresis'], PlayHysteresis):
            d['hysteresis'] = PlayHysteresis.from_dict(d['hysteresis'])
        return cls(**d)


# ------------------------------------------------------------------ derived from the declaration
#: name -> ParamSpec of every declared parameter, in field order
PARAMETERS: Dict[str, ParamSpec] = {f.name: f.metadata[SPEC] for f in fields(ActuatorParams)
                                    if SPEC in f.metadata}
#: parameters of the catalog effects, effect name -> names
EFFECT_PARAMETERS: Dict[str, Tuple[str, ...]] = {}
for _name, _spec in PARAMETERS.items():
    if _spec.effect:
        EFFECT_PARAMETERS.setdefault(_spec.effect, ())
        EFFECT_PARAMETERS[_spec.effect] += (_name,)
#: parameters with a range in the plant node (every effect parameter)
PLANT_PARAMETERS = tuple(k for k, s in PARAMETERS.items() if s.plant is not None)
FEEDBACK_PARAMS = tuple(k for k, s in PARAMETERS.items() if s.role in ROLES)
LINEAR_PARAMS = tuple(k for k, s in PARAMETERS.items() if s.role == LINEAR)
#: the kernel's parameters: T and G (derived from the wire fields), then the declared ones
KERNEL_PARAMS = ('tau_s', 'gain_k') + tuple(k for k, s in PARAMETERS.items() if s.kernel)
KernelParams = namedtuple('KernelParams', KERNEL_PARAMS)
#: each kernel parameter's slot in the vector: the kernel reads p[SLOT.tau_s], ...
SLOT = KernelParams(*range(len(KERNEL_PARAMS)))
_kernel_values = attrgetter(*KERNEL_PARAMS)


def name_in_unit(name: str, position_unit: str) -> str:
    """
    Return parameter `name` as shown for a rig whose position is in `position_unit`.

    A `_rad` parameter holds a position, in whatever unit the rig measures it (its
    `ParamSpec` unit is 'rad'), so it is shown with that unit: `offset_rad` is `offset_mm`
    on a rig read in mm (`%` spelt `pct`). A `_rad` parameter of another declared unit
    (the sensor terms, relative to the half travel h) is shown without the suffix. Other
    names, and every name on a rig in rad, stay as they are.
    """
    if position_unit in ('', 'rad') or not name.endswith('_rad'):
        return name
    stem, spec = name[:-len('_rad')], PARAMETERS.get(name)
    if spec is not None and spec.unit != 'rad':
        return stem
    return f"{stem}_{'pct' if position_unit == '%' else position_unit}"


def fit_table(effect: str) -> Dict[str, Tuple[float, float, float]]:
    """
    Return {parameter: (lower, upper, start)} of the parameters `effect` frees.

    In declaration order, searched parameters first and the LINEAR ones (solved with the
    weights) last.
    """
    names = EFFECT_PARAMETERS.get(effect, ())
    ordered = sorted(names, key=lambda k: PARAMETERS[k].role == LINEAR)
    return {k: PARAMETERS[k].fit for k in ordered}


# kernel state layout: wire j's entry is at offset + j; the element states of wire j follow
# STATE_ELEMENTS + j m (m elements each), then the two hysteresis inputs
STATE_THETA = 0         # wire temperatures θ_a, θ_b [°C]
STATE_HEAT = 2          # heat-input lags q_a, q_b [K]
STATE_CONTRACTION = 4   # contraction fractions y_a, y_b
STATE_ELEMENTS = 6      # play element states s_a (m), s_b (m)
# the latent-heat root (`latent_temperature`): bracket width [K] and step limit
LATENT_TOL_K = 1e-10
LATENT_ITERATIONS = 60


# argument tuples of `simulate_wires`
KernelInputs = Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
KernelHysteresis = Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, float]
KernelFeatures = Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int]


@njit(cache=True)
def simulate_wires(inputs: KernelInputs, dt: float, p: np.ndarray, hyst: KernelHysteresis,
                   state: np.ndarray, features: KernelFeatures
                   ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """
    Step 1-3 of the module docstring for n samples; returns (y_a, y_b, θ_a, θ_b).

    inputs = (duty_a, duty_b, ambient [°C], disturbance [K]): length-n arrays, sample k held
    over [t_k, t_k + dt). Outputs follow the sampled-data convention: sample k is the state
    at t_k, before duty k acts (a measurement taken when the command is sent).
    p: `ActuatorParams.kernel_vector()`, read by name (p[SLOT.tau_s], ...);
    hyst = (r, lo, hi, w, k1, y0): the shared hysteresis of eq. (K1)-(K2) (`core.kernels`).
    state (updated in place, ends at t_n): the layout of the STATE_* offsets,
    [θ_a, θ_b, q_a, q_b, y_a, y_b, s_a (N), s_b (N), u_a, u_b] with u the hysteresis inputs.
    features = (feat_a, feat_b, u_a, u_b, start, step), feat (R, N) and u (R,): when R > 0,
    filled with the element states and hysteresis inputs at samples start + i step, i < R
    (the regressors of identification, recorded only at the regression rows: the
    full-rate arrays would be mostly thrown away); `NO_FEATURES` records none.
    """
    duty_a, duty_b, ambient, disturbance = inputs
    r, lo, hi, w, k1, y0 = hyst
    feat_a, feat_b, u_a, u_b, feat_start, feat_step = features
    tau, gain, amb0, tau_f = p[SLOT.tau_s], p[SLOT.gain_k], p[SLOT.ambient_c], p[SLOT.tau_fast_s]
    conv_n, k_amb, kappa = p[SLOT.convection_exponent], p[SLOT.ambient_gain], p[SLOT.phase_kappa]
    sigma, g_b, t_b = p[SLOT.stress_k], p[SLOT.gain_ratio_b], p[SLOT.tau_ratio_b]
    latent = p[SLOT.latent_heat_k]
    d_lim, sharp = p[SLOT.duty_limit], p[SLOT.duty_limit_sharpness]
    n = duty_a.shape[0]
    m = r.shape[0]
    out_ya = np.empty(n)
    out_yb = np.empty(n)
    out_ta = np.empty(n)
    out_tb = np.empty(n)
    n_rows = feat_a.shape[0]
    iu = STATE_ELEMENTS + 2 * m
    weighted = np.nonzero(w)[0]
    for k in range(n):
        # record the state at t_k
        out_ta[k], out_tb[k] = state[STATE_THETA], state[STATE_THETA + 1]
        out_ya[k], out_yb[k] = state[STATE_CONTRACTION], state[STATE_CONTRACTION + 1]
        row = (k - feat_start) // feat_step
        if k >= feat_start and row < n_rows and (k - feat_start) % feat_step == 0:
            for i in range(m):
                feat_a[row, i] = state[STATE_ELEMENTS + i]
                feat_b[row, i] = state[STATE_ELEMENTS + m + i]
            u_a[row] = state[iu]
            u_b[row] = state[iu + 1]
        # advance to t_k + dt
        th_amb = amb0 + k_amb * (ambient[k] - amb0)
        y_prev_a = state[STATE_CONTRACTION]
        y_prev_b = state[STATE_CONTRACTION + 1]
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
            theta = state[STATE_THETA + j]
            if conv_n != 0.0:   # hA(θ) / hA_ref; below 0.5 K excess the law is held constant
                f = max((max(abs(theta - th_amb), 0.5) / CONVECTION_REF_K) ** conv_n, 0.05)
                g = g / f
                t = t / f
            q_inf = g * d * (1.0 + kappa * (1.0 - y_own))
            theta, q = thermal_step(theta, state[STATE_HEAT + j], th_amb, q_inf, dt, t, tau_f)
            state[STATE_THETA + j] = theta
            state[STATE_HEAT + j] = q
            shift = disturbance[k] - sigma * y_other
            base = STATE_ELEMENTS + j * m
            if latent > 0.0:
                theta = latent_temperature(theta, shift, y_own, latent, state[base:base + m],
                                           hyst, weighted)
            u = theta + shift
            state[iu + j] = u
            # the element update carries no sum from element to element, so it vectorises;
            # the sum then runs over the nonzero weights only (a fitted w is sparse)
            for i in range(m):
                v = min(max(state[base + i], u - r[i]), u + r[i])
                state[base + i] = min(max(v, lo[i]), hi[i])
            acc = y0 + k1 * u
            for i in weighted:
                acc += w[i] * state[base + i]
            state[STATE_CONTRACTION + j] = acc
            state[STATE_THETA + j] = theta
    return out_ya, out_yb, out_ta, out_tb


@njit(cache=True)
def contraction_at(u: float, s: np.ndarray, hyst: KernelHysteresis,
                   weighted: np.ndarray) -> float:
    """
    Return y = y0 + k1 u + Σ w_i clip(clip(s_i, u − r_i, u + r_i), lo_i, hi_i) (K1-K2).

    weighted: the indices i with w_i != 0, in order (the other terms are zero).
    """
    r, lo, hi, w, k1, y0 = hyst
    acc = y0 + k1 * u
    for i in weighted:
        acc += w[i] * min(max(min(max(s[i], u - r[i]), u + r[i]), lo[i]), hi[i])
    return acc


@njit(cache=True)
def latent_temperature(theta_pred: float, shift: float, y_own: float, latent: float,
                       s: np.ndarray, hyst: KernelHysteresis, weighted: np.ndarray) -> float:
    """
    Return θ after the sample's latent heat: the root of θ = θ_pred − λ (H(θ + shift) − y).

    The heat the transformation absorbs or releases over the sample is taken at the
    sample's end (backward Euler of C dθ/dt = ... − L dξ/dt, λ = L / C): θ_pred is the
    thermal step without it, H the wire's hysteresis from its element states `s` before
    the sample, y its contraction before it. The explicit form θ_pred − λ (H(θ_pred + shift)
    − y) overshoots wherever λ dH/dθ > 1 (a steep loop, strong latent heat) and then
    chatters from sample to sample, so the output jumps with the parameters. H is
    non-decreasing (w, k1 >= 0), so the root is unique and lies between θ_pred and
    θ_pred − λ (H(θ_pred + shift) − y); found by regula falsi (Illinois), exact in a few
    steps on the piecewise-linear H. weighted: as in `contraction_at`.
    """
    excess = latent * (contraction_at(theta_pred + shift, s, hyst, weighted) - y_own)
    if excess == 0.0:
        return theta_pred
    t_lo, t_hi = min(theta_pred, theta_pred - excess), max(theta_pred, theta_pred - excess)
    f_lo = t_lo - theta_pred + latent * (contraction_at(t_lo + shift, s, hyst, weighted) - y_own)
    f_hi = t_hi - theta_pred + latent * (contraction_at(t_hi + shift, s, hyst, weighted) - y_own)
    if f_lo >= 0.0:
        return t_lo
    if f_hi <= 0.0:
        return t_hi
    side = 0
    t = t_hi
    for _ in range(LATENT_ITERATIONS):
        t = (t_lo * f_hi - t_hi * f_lo) / (f_hi - f_lo)
        f = t - theta_pred + latent * (contraction_at(t + shift, s, hyst, weighted) - y_own)
        if f == 0.0 or t_hi - t_lo < LATENT_TOL_K:
            break
        if f < 0.0:
            t_lo, f_lo = t, f
            if side < 0:
                f_hi *= 0.5
            side = -1
        else:
            t_hi, f_hi = t, f
            if side > 0:
                f_lo *= 0.5
            side = 1
    return t


#: `simulate_wires` features argument that records no regressors
NO_FEATURES = (np.zeros((0, 0)), np.zeros((0, 0)), np.zeros(0), np.zeros(0), 0, 1)


def kernel_hysteresis(h: PlayHysteresis) -> KernelHysteresis:
    """Return the hyst argument of `simulate_wires`, (r, lo, hi, w, k1, y0) of `h`."""
    return h.r, h.lo, h.hi, h.w, h.k1, h.y0


def kernel_inputs(duty_a: ArrayLike, duty_b: ArrayLike, ambient_c: ArrayLike,
                  disturbance_k: ArrayLike) -> KernelInputs:
    """Return the inputs argument of `simulate_wires`, each a `kernels.kernel_array`."""
    return tuple(map(kernel_array, (duty_a, duty_b, ambient_c, disturbance_k)))


def initial_state(params: ActuatorParams, theta_c: Optional[float] = None) -> np.ndarray:
    """
    Return the kernel state at rest (STATE_* layout).

    Both wires at ambient (or theta_c), no heat in the lag, cold branch of the hysteresis.
    """
    h = params.hysteresis
    theta = params.ambient_c if theta_c is None else finite_scalar('theta_c', theta_c)
    s = h.initial_state(theta)
    y = h.y0 + h.k1 * theta + float(h.w @ s)
    return np.concatenate([[theta, theta, 0.0, 0.0, y, y], s, s, [theta, theta]])


def shaft_angle(params: ActuatorParams, y_a: ArrayLike, y_b: ArrayLike,
                cycles_a: Optional[ArrayLike] = None,
                cycles_b: Optional[ArrayLike] = None) -> np.ndarray:
    """
    Return the shaft angle of step 4 [rad].

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


def transformation_cycles(y: ArrayLike, n0: float = 0.0) -> np.ndarray:
    """
    Return the accumulated transformation cycles of one wire, N = n0 + Σ|Δy| / 2 per sample.

    A full contraction and release counts 1.
    """
    y = np.asarray(y, float)
    return n0 + 0.5 * np.cumsum(np.abs(np.diff(y, prepend=y[0])))


def fatigue_progress(params: ActuatorParams, cycles: ArrayLike) -> np.ndarray:
    """Return the shakedown fraction g(N) = 1 − exp(−N / N_f) of functional fatigue."""
    return -np.expm1(-np.asarray(cycles) / params.fatigue_cycles)


def sensor_polynomial(params: ActuatorParams, phi: ArrayLike) -> np.ndarray:
    """
    Return the potentiometer reading, step 5 without the delay.

    p(φ) = φ + h (c2 x² + c3 x³ + c4 x⁴ + c5 x⁵), x = (φ − φc) / h [rad]; with the
    neutral φc = 0, h = 1 this is φ + c2 φ² + ... + c5 φ⁵.
    """
    h = params.sensor_half_span_rad
    x = (np.asarray(phi, float) - params.sensor_centre_rad) / h
    return phi + h * x * x * (params.sensor_c2_rad + x * (params.sensor_c3_rad + x * (
        params.sensor_c4_rad + x * params.sensor_c5_rad)))


def sensor_is_linear(params: ActuatorParams) -> bool:
    """Return True when the potentiometer polynomial is the identity, p(φ) = φ (no terms)."""
    return not (params.sensor_c2_rad or params.sensor_c3_rad or params.sensor_c4_rad
                or params.sensor_c5_rad)


def sensor_rising_branch(params: ActuatorParams, angles_rad: np.ndarray) -> tuple:
    """
    Return (readings, angles) [rad] of p on its rising branch through the middle of `angles_rad`.

    p (`sensor_polynomial`) tabulated on the increasing `angles_rad` and cut where it first
    stops rising on either side of the middle sample: the part np.interp can invert.
    """
    p = sensor_polynomial(params, angles_rad)
    falls = np.flatnonzero(np.diff(p) <= 0)        # p[i + 1] <= p[i]
    mid = len(angles_rad) // 2
    a = int(falls[falls < mid].max()) + 1 if np.any(falls < mid) else 0
    b = int(falls[falls >= mid].min()) if np.any(falls >= mid) else len(angles_rad) - 1
    return p[a:b + 1], angles_rad[a:b + 1]


def sensor_inverse(params: ActuatorParams, reading: ArrayLike,
                   n_grid: int = 8193) -> np.ndarray:
    """
    Return the angle φ with p(φ) = reading, `sensor_polynomial` inverted [rad].

    p is evaluated on a dense grid over the readings' span widened by that span each
    side, and inverted by interpolation on its rising branch through the middle of the
    readings. Where that branch does not reach every reading (the bounds allow p to turn
    far from the travel), the first-order inverse 2y − p(y), exact to O(c²), is returned.
    """
    y = np.asarray(reading, float)
    if sensor_is_linear(params):
        return y
    lo, hi = float(np.min(y)), float(np.max(y))
    span = max(hi - lo, 1e-3)
    p, phi = sensor_rising_branch(params, np.linspace(lo - span, hi + span, n_grid))
    if p[0] <= lo and p[-1] >= hi:
        return np.interp(y, p, phi)
    return 2.0 * y - sensor_polynomial(params, y)


def delay_signal(x: np.ndarray, dt: float, delay_s: float) -> np.ndarray:
    """
    Return x(t − D) on the sample grid.

    Linear interpolation, holding the first value before t0.
    """
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


def simulate(params: ActuatorParams, duty_a: ArrayLike, duty_b: ArrayLike, dt: float,
             ambient_c: Optional[ArrayLike] = None, disturbance_k: Optional[ArrayLike] = None,
             state: Optional[np.ndarray] = None) -> Trajectory:
    """
    Simulate the whole actuator (steps 1-5) free-running for duty sequences at step dt [s].

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
    st = initial_state(params) if state is None else state
    ya, yb, ta, tb = simulate_wires(kernel_inputs(duty_a, duty_b, amb, dist), dt,
                                    params.kernel_vector(),
                                    kernel_hysteresis(params.hysteresis), st, NO_FEATURES)
    phi = shaft_angle(params, ya, yb, transformation_cycles(ya), transformation_cycles(yb))
    phi = sensor_polynomial(params, phi)
    return Trajectory(delay_signal(phi, dt, params.delay_s), ta, tb, ya, yb)


_THETA = slice(STATE_THETA, STATE_THETA + 2)
_CONTRACTION = slice(STATE_CONTRACTION, STATE_CONTRACTION + 2)


class AntagonisticActuator:
    """
    Streaming form of `simulate` for nodes: `step(duty_a, duty_b, dt)` -> shaft angle [rad].

    Long steps are split into sub-steps of at most `max_substep_s` so the feedback effects
    (phase resistance, stress coupling, convection) stay accurate at any call rate.
    """

    def __init__(self, params: Optional[ActuatorParams] = None,
                 max_substep_s: float = 0.005) -> None:
        self.params = ActuatorParams() if params is None else params
        self.max_substep_s = float(max_substep_s)
        self.reset()

    def reset(self, theta_c: Optional[float] = None) -> None:
        """Put both wires at ambient (or theta_c), cold and fully martensitic, shaft at rest."""
        self._state = initial_state(self.params, theta_c)
        self._time = 0.0
        self._cycles = np.zeros(2)         # per wire
        self._history = [(0.0, self._measured(*self._state[_CONTRACTION]))]

    @property
    def temperature_c(self) -> np.ndarray:
        """Wire temperatures [θ_a, θ_b] in °C."""
        return self._state[_THETA].copy()

    @property
    def contraction(self) -> np.ndarray:
        """Contraction fractions [y_a, y_b] (0 cold, 1 fully contracted)."""
        return self._state[_CONTRACTION].copy()

    @property
    def reading_now(self) -> float:
        """Sensed shaft angle [rad] at the present time, before the transport delay."""
        return self._history[-1][1]

    def _measured(self, y_a: float, y_b: float) -> float:
        phi = shaft_angle(self.params, y_a, y_b, self._cycles[0], self._cycles[1])
        return float(sensor_polynomial(self.params, phi))

    def step(self, duty_a: float, duty_b: float, dt: float, ambient_c: Optional[float] = None,
             disturbance_k: float = 0.0) -> float:
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
        y_before = self._state[_CONTRACTION].copy()
        inputs = (np.full(n_sub, float(duty_a)), np.full(n_sub, float(duty_b)),
                  np.full(n_sub, amb), np.full(n_sub, dist))
        simulate_wires(inputs, dt / n_sub, self.params.kernel_vector(),
                       kernel_hysteresis(self.params.hysteresis), self._state, NO_FEATURES)
        self._cycles += 0.5 * np.abs(self._state[_CONTRACTION] - y_before)
        self._time += dt
        self._history.append((self._time, self._measured(*self._state[_CONTRACTION])))
        return self._delayed()

    def _delayed(self) -> float:
        delay = self.params.delay_s
        t_query = self._time - delay
        # drop history older than needed, keep one sample before t_query for interpolation
        while len(self._history) > 2 and self._history[1][0] <= t_query:
            self._history.pop(0)
        if delay <= 0:
            return self._history[-1][1]
        times, values = zip(*self._history)
        return float(np.interp(t_query, times, values))
