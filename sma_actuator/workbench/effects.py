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
Catalog of physical effects the base model (the paper's) may lack.

Each effect is a small class for behaviour only: its docstring states the physics and
`signature` says what the residual of a model without it looks like. Its `parameters`,
the `ActuatorParams` fields it frees with their (lower, upper, start) fit bounds, derive
from the fields' declarations (`ParamSpec.effect`, `core.actuator`); the physics itself
lives in `sma_actuator.core.actuator` (one implementation, shared with the plant node).
docs/architecture.md has the recipe for a new effect.

Plug-in point: subclass `Effect` in your own module and call `register_effect(cls)`
(or expose the module under the `sma_actuator.effects` entry-point group / pass it to
`sma-model --plugin`). A plug-in effect may free existing ActuatorParams fields and may
bring parameters of its own that act through `transform_inputs` (duties and ambient
before the thermal model), e.g. a supply that sags with load or a PWM dead time. Such
parameters are declared once too, as `ParamSpec`s in `declares`, from which `parameters`
follows.
"""
from __future__ import annotations

from typing import Any, Dict, List, Optional, Tuple, TYPE_CHECKING

import numpy as np

from ..core.actuator import fit_table

if TYPE_CHECKING:
    from ..core.actuator import ActuatorParams
    from ..core.datakinds import DynamicData, StaticData

    Data = DynamicData | StaticData

# (lower, upper, start) of one fitted parameter
Bounds = Tuple[float, float, float]


class Effect:
    """Base class of a catalog effect (see module docstring)."""

    name = ''
    signature = ''
    parameters = {}       # ActuatorParams field (or 'tau_s') -> (lower, upper, start)
    needs_dynamic = True  # needs time-series data (not quasi-static curves)
    kind = None           # hysteresis kind the effect requires ('modified' for saturation)
    # in diagnose, also refit from scratch besides on the base fit's hysteresis grid (the
    # better training fit is kept): for effects that can move the operating temperatures
    # so far that the base grid sits in the wrong place
    own_grid = False
    # acts between the two wires: not applicable to a single wire against a bias spring
    needs_two_wires = False
    # changes how the duty becomes temperature: not identified by records that heat at one
    # duty level, so diagnose does not name it there (`judging.unresolved_by`)
    heating_law = False
    # retards the response to the duty: a dead time d and a first-order lag of about d shift
    # it alike to first order in ω d, so diagnose ranks two such rivals by their training
    # fit where one fits it clearly better (`diagnosis.rank_candidates`)
    retards_response = False
    # plug-in parameters of its own: name -> `core.actuator.ParamSpec` (its fit is used)
    declares = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """
        Derive `parameters` from the declarations.

        The `ActuatorParams` fields declared with this effect's name, then its own
        `declares`; a class that declares nothing keeps what it states or inherits.
        """
        super().__init_subclass__(**kwargs)
        own = cls.__dict__.get('declares', {})
        table = dict(fit_table(cls.name), **{k: spec.fit for k, spec in own.items()})
        if table and 'parameters' not in cls.__dict__:
            cls.parameters = table

    def scratch_start(self, params: ActuatorParams) -> Dict[str, float]:
        """
        Return start values of the from-scratch refit (`own_grid`) for a model with `params`.

        Default: the same as the warm start.
        """
        return {}

    def scratch_bounds(self, params: ActuatorParams) -> Dict[str, Bounds]:
        """
        Return (lower, upper, start) of parameters bounded differently from scratch.

        In the from-scratch refit (`own_grid`) of the base fit `params`, e.g. the base's 'tau_s';
        default none.
        """
        return {}

    @property
    def doc(self) -> str:
        """Return the physics docstring."""
        return ' '.join((self.__doc__ or '').split())

    def applicable(self, data: Data) -> Optional[str]:
        """Return None if the effect can be fitted on `data`, else the reason it cannot."""
        return None

    def bounds(self, params: ActuatorParams) -> Dict[str, Bounds]:
        """
        Return (lower, upper, start) per parameter for a model with `params` (ActuatorParams).

        Default: the `parameters` table.
        """
        return dict(self.parameters)

    def start_values(self, data: Data) -> Dict[str, float]:
        """Return start values of the parameters for `data` (default: the table's start)."""
        return {k: v[2] for k, v in self.parameters.items()}

    def alternative_starts(self, data: Data) -> List[Dict[str, float]]:
        """Return further starts, tried when the fit may have several minima (default none)."""
        return []

    def unresolved(self, values: Dict[str, float], data: Data) -> Optional[str]:
        """
        Return None if the data can resolve the effect at the fitted `values`, else why not.

        Diagnose then does not call it significant. Default None.
        """
        return None

    def transform_inputs(
        self, duty_a: np.ndarray, duty_b: np.ndarray, ambient: np.ndarray,
        values: Dict[str, float],
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """
        Return the inputs (arrays) the thermal model sees (plug-in hook).

        Given this effect's parameter values (dict).
        Duties must stay in [0, 1]. Identity by default.
        """
        return duty_a, duty_b, ambient


class Saturation(Effect):
    """
    Hysteresis saturation.

    The transformation of NiTi is complete at both ends (all martensite cold, all austenite hot),
    so contraction stops growing however far the temperature moves. The classical
    Prandtl-Ishlinskii operator of eq. (5) keeps growing linearly; the modified operator of eq. (6)
    (backlash with saturation) does not.
    """

    name = 'saturation'
    signature = ('error grows at the ends of travel; the model overshoots where the '
                 'measured loop flattens; residual correlates with |position|')
    needs_dynamic = False
    kind = 'modified'


class FastDynamics(Effect):
    """
    Unmodelled fast dynamics τ of the paper's Fig. 13.

    A first-order lag on the heat input (heat spreading from core to surface, amplifier
    filtering), so the wire responds to a duty step with an S-shaped rather than exponential
    temperature rise.
    """

    name = 'fast_dynamics'
    heating_law = True
    retards_response = True
    # also from scratch: without the lag the base grid sits at lag-distorted temperatures
    own_grid = True

    def alternative_starts(self, data: Data) -> List[Dict[str, float]]:
        """Also start at a slow lag: it trades off against the basic time constant."""
        return [{'tau_fast_s': 0.5}]

    def scratch_bounds(self, params: ActuatorParams) -> Dict[str, Bounds]:
        """
        Keep τ the slow lag in the from-scratch refit.

        The two lags in series are interchangeable (G / ((τ s + 1)(τ_fast s + 1))), and
        from scratch the search can end in the swapped pair, τ at its lower bound and the
        slow lag in τ_fast, which the hysteresis then fits worse. Keep τ the slow one: the
        base fit's single lag has about the pair's mean delay τ + τ_fast, so τ >= τ_fast
        means τ >= τ_base / 2.
        """
        return {'tau_s': (0.5 * params.tau_s, 20.0, params.tau_s)}

    def unresolved(self, values: Dict[str, float], data: Data) -> Optional[str]:
        """
        Return why a lag below half a sample period is not resolved.

        A lag τ_fast much shorter than τ acts on the slow response as a delay of τ_fast
        (1 / (τ_fast s + 1) ≈ e^(−τ_fast s)); below half a sample period it is a sub-sample
        shift, which `Delay.unresolved` calls sample alignment too.
        """
        dt = getattr(data, 'dt', None)
        if dt and values.get('tau_fast_s', np.inf) < 0.5 * dt:
            return (f'the fitted lag {1e3 * values["tau_fast_s"]:.0f} ms is below half a sample '
                    f'period ({1e3 * dt:.0f} ms): a sub-sample shift (sample alignment), not '
                    'a resolved lag')
        return None
    signature = ('residual spikes right after duty steps, same sign as the step; '
                 'residual correlates with the duty rate')


class Delay(Effect):
    """
    Transport delay between command and measured position.

    Serial link, filtering in the sensor chain, PWM update latency: the whole response is
    shifted in time.
    """

    name = 'delay'
    retards_response = True
    # also from scratch, like fast_dynamics: a plant record with a 0.3 s delay refitted
    # warm reached 0.12 % training NRMSE and lost to fast_dynamics from scratch (0.10 %);
    # from scratch the delay fits to the noise (0.05 %, 0.3015 s)
    own_grid = True

    def alternative_starts(self, data: Data) -> List[Dict[str, float]]:
        """Also start at a long delay: it sits in another basin of the error surface."""
        return [{'delay_s': 0.3}]

    def unresolved(self, values: Dict[str, float], data: Data) -> Optional[str]:
        """
        Return why a delay below one sample period is not a transport delay.

        It is how the recorder aligned duty and position samples (zero-order hold over the
        interval).
        """
        dt = getattr(data, 'dt', None)
        if dt and values.get('delay_s', 0.0) < dt:
            return (f'the fitted delay {1e3 * values["delay_s"]:.0f} ms is below one sample '
                    f'period ({1e3 * dt:.0f} ms): sample alignment, not a transport delay')
        return None
    signature = ('residual looks like the derivative of the position (leads the motion); '
                 'cross-correlation of residual and position rate peaks at lag 0')


class Convection(Effect):
    """
    Temperature-dependent heat transfer.

    Natural convection from a thin wire follows Nu ∝ Ra^n, so the film coefficient grows with the
    excess temperature as h ∝ ΔT^n (n ≈ 0.06-0.25 for thin wires, radiation adds to it), hA(θ) =
    hA_ref (|θ − θa| / 50 K)^n:

    a hot wire loses heat faster and settles cooler than the linear eq. (7) predicts, and a
    wire near ambient cools more slowly.
    """

    name = 'convection'
    heating_law = True
    signature = ('error depends on temperature level: model too hot (over-contracted) at '
                 'high duty, cooling faster than modelled; residual correlates with temperature')


class AmbientDrift(Effect):
    """
    Ambient temperature changes during the run: eq.

    (7) loses heat to the actual ambient θa(t) (measured), not to a constant, shifting every
    temperature and so the position at a given duty.
    """

    name = 'ambient_drift'
    # a drifting ambient shifts every temperature; without it the base fit (often with a
    # wrong time constant) puts its grid where the wires would be at constant ambient
    own_grid = True
    signature = ('slow residual that follows the measured ambient temperature; '
                 'cross-correlation with ambient well outside the 99 % band')

    def applicable(self, data: Data) -> Optional[str]:
        """Return why not unless a measured ambient_temperature actually varies."""
        amb = getattr(data, 'ambient', None)
        if amb is None:
            return 'no ambient_temperature column in the data'
        if np.ptp(amb) < 0.5:
            return 'measured ambient varies by less than 0.5 K'
        return None


class PhaseResistance(Effect):
    """
    Electrical resistance depends on phase.

    Martensite has a higher resistivity than austenite, so at a given duty the Joule power R i²
    (current-limited) or V²/R changes as the wire transforms: P = P0 d (1 + κ (1 − y)), y the
    contraction fraction.
    """

    name = 'phase_resistance'
    heating_law = True

    def bounds(self, params: ActuatorParams) -> Dict[str, Bounds]:
        """
        Bound κ to the sign the drive gives it.

        A wire's resistance falls as it contracts (martensite R_M above austenite R_A, the basis
        of SMA self-sensing), so a current-limited amplifier (P = R I_max², V/R > I_max) heats
        martensite more (κ >= 0) and a voltage drive (P = V²/R) heats it less (κ <= 0). Without
        this a wrong-signed κ would act as a generic correction of the hysteresis shape.
        """
        limited = params.supply_v / params.resistance_ohm > params.current_limit_a
        return {'phase_kappa': (0.0, 0.5, 0.1) if limited else (-0.5, 0.0, -0.1)}

    def start_values(self, data: Data) -> Dict[str, float]:
        """Start inside the drive's sign range (see `bounds`)."""
        return {}

    # heating from martensite runs hotter (or cooler) than the base model's, so the base
    # grid sits where the base put the transformation and a refit on it cannot reach the
    # true kappa; from scratch the search does not leave kappa ~ 0 (the coarse grid hides
    # the effect), so that refit starts from a strong effect.
    own_grid = True

    def scratch_start(self, params: ActuatorParams) -> Dict[str, float]:
        """Start the from-scratch refit from a strong effect of the drive's sign."""
        lo, hi, start = self.bounds(params)['phase_kappa']
        return {'phase_kappa': 0.7 * (hi if start > 0 else lo)}
    signature = ('heating from cold is faster (or slower) than modelled while cooling '
                 'matches; error concentrated in heating from the martensite side')


class LatentHeat(Effect):
    """
    Latent heat of the transformation.

    The martensite -> austenite transformation absorbs heat and the reverse gives it back
    (about 20 J/g for NiTi), so eq. (7) gains a term: C dθ/dt = P − hA (θ − θa) − L dξ/dt.
    Per sample, θ = θ_pred − λ Δy with Δy taken at the sample's end (λ = L / C [K] per unit
    contraction, `core.actuator.latent_temperature`): heating stalls while the wire
    transforms and cooling holds the wire hot until the reverse transformation is done.
    """

    name = 'latent_heat'
    heating_law = True
    signature = ('transformations run slower and more evenly in time than modelled: the '
                 'model heats and cools through the loop too fast at first and too slowly at '
                 'the end (an S that is too steep at its start)')
    # the heat held in the transformation moves the temperatures at which the wire
    # transforms, so the base grid sits where the base put the transformation; from
    # scratch the search does not leave a small λ (the coarse grid hides the effect), so
    # that refit starts from a strong one
    own_grid = True

    def scratch_start(self, params: ActuatorParams) -> Dict[str, float]:
        """Start the from-scratch refit from half the upper bound: a strong effect."""
        _, upper, _ = self.bounds(params)['latent_heat_k']
        return {'latent_heat_k': 0.5 * upper}


class StressCoupling(Effect):
    """
    Stress coupling of the antagonistic pair.

    When one wire contracts it stretches the other, raising its stress and, by Clausius-Clapeyron
    (~6-7 MPa/K), its transformation temperatures; equivalently the wire sees an effective
    temperature lowered by σ y_other.
    """

    name = 'stress_coupling'
    needs_two_wires = True
    signature = ('loop of each wire shifts with the state of the other: error larger when '
                 'the antagonist is contracted (near the ends of travel), depends on history')


class AsymmetricWires(Effect):
    """
    The two wires differ (length, diameter, resistance, crimping, pre-strain).

    Heating gain, time constant and stroke of wire b relative to wire a are free.
    """

    name = 'asymmetric_wires'
    needs_two_wires = True
    signature = ('error has opposite character on the two sides: one direction too fast or '
                 'too far, the other too slow or short; residual correlates with sign of position')

    def alternative_starts(self, data: Data) -> List[Dict[str, float]]:
        """
        Also start with wire b heating √2 times more, and √2 times less, than wire a.

        From the equal pair the search can trade the heating gain for the stroke and end
        at a bound of the stroke ratio; a start on either side of the pair (halfway to
        each bound of the gain ratio [0.5, 2], in log: √(lower), √(upper)) reaches the
        other basin.
        """
        lower, upper = self.parameters['gain_ratio_b'][:2]
        return [{'gain_ratio_b': np.sqrt(upper)}, {'gain_ratio_b': np.sqrt(lower)}]


class SensorNonlinearity(Effect):
    """
    Potentiometer nonlinearity.

    Track resistance is not uniform and the wiper loads the divider, so the reading is a smooth
    function of the angle, here the polynomial p(φ) = φ + h (c2 x² + c3 x³ + c4 x⁴ + c5 x⁵) of the
    travel scaled to ±1, x = (φ − φc) / h (enough for bow and S shapes; φc and h from the
    measured travel, so the terms mean the same in any unit).
    """

    name = 'sensor_nonlinearity'
    signature = ('static, memoryless error that is a smooth function of the position '
                 '(bow or S-shape in the residual-vs-position plot), same on both branches')


class FatigueDrift(Effect):
    """
    Functional fatigue.

    With its accumulated transformation cycles N_j each wire loses recoverable strain and elongates
    plastically (stabilised martensite), most of it in the first cycles (shakedown). Each wire
    fatigues by its own use: stroke loss f_s g_j and a zero drift f_j g_j of the shaft, g_j = 1 −
    exp(−N_j / N_f), N_j = Σ|Δy_j| / 2.
    """

    name = 'fatigue_drift'
    signature = ('residual trends with time: its mean and amplitude differ between time '
                 'quartiles; validation error much larger than training error')

    def alternative_starts(self, data: Data) -> List[Dict[str, float]]:
        """Also start at a slow (nearly linear) drift: another basin than a quick shakedown."""
        return [{'fatigue_cycles': 500.0}]


class CurrentLimit(Effect):
    """
    Current limiter of the amplifier engages within the used duty range.

    The mean current, and so the heating power, stops rising above a duty d_lim (eq. 7's R i²
    saturates), so high duties heat less than the linear PWM law predicts. Current ripple rounds
    the corner: sat(d) = d_lim x / (1 + x^n)^(1/n), x = d / d_lim, n free.
    """

    name = 'current_limit'
    heating_law = True
    signature = ('model over-heats only at the highest duties: error at full contraction '
                 'after large duty steps, none at small duties')

    def start_values(self, data: Data) -> Dict[str, float]:
        """Start below the largest duty used, where the limit has an effect to fit."""
        top = float(max(np.max(data.duty_a), np.max(data.duty_b)))
        return {'duty_limit': float(np.clip(0.85 * top, 0.02, 1.0))}

    def alternative_starts(self, data: Data) -> List[Dict[str, float]]:
        """
        Also start from a limit that is not engaged (the base model itself).

        a weak limit is a small departure from there, not from a knee inside the duty range.
        """
        return [{'duty_limit': 1.0, 'duty_limit_sharpness': 30.0}]


class PerRecordEffect(Effect):
    """Base of the effects with a value per record of a record set (two or more records)."""

    per_record = ''   # what each record has its own of

    def applicable(self, data: Data) -> Optional[str]:
        """Return why not: the value is per record, so it needs two or more records."""
        if len(getattr(data, 'segments', ()) or ()) < 2:
            return f'needs two or more records (a {self.per_record} per record)'
        return None


class SensorZero(PerRecordEffect):
    """
    Per-record sensor zero: a potentiometer is not tared between runs.

    Runs of one rig taken on other days rest at other readings, so each record's position
    is taken relative to its own rest before the first heating (the mean of the first
    second, or up to the first duty above zero), and the model predicts the departure from
    that rest. Needs two or more records.
    """

    name = 'sensor_zero'
    per_record = 'sensor zero'
    signature = ('each record is off by its own constant: the residual mean differs from '
                 'record to record, already at rest before the first heating')


class RecordStroke(PerRecordEffect):
    """
    Per-record stroke: a wire's stroke changes from day to day (shakedown, retensioning).

    The contraction of record k is ρ_k times the model's: position = rest_k + ρ_k (φ −
    φ_rest), with rest_k the record's start rest and φ the model's shaft output. ρ_k is the
    least-squares factor of a pooled fit's departure from rest onto the measured one,
    referred to the median training record (ρ = 1 there); the model is then refitted on the
    records scaled back to that stroke. A held-out or new record's stroke is unknown
    before it is measured: it is predicted with the median training record's stroke
    (ρ = 1). Needs two or more records.
    """

    name = 'record_stroke'
    per_record = 'stroke'
    signature = ('each record is off by its own factor: the residual follows the position '
                 'with a slope that differs from record to record, zero at rest')


CATALOG = {}


def register_effect(cls: type) -> type:
    """Add an Effect subclass to the catalog (the plug-in point) and return it."""
    if not (isinstance(cls, type) and issubclass(cls, Effect)) or not cls.name:
        raise ValueError('a plug-in effect must be an Effect subclass with a name')
    CATALOG[cls.name] = cls()
    return cls


# the package's own effects: every process that imports this module has them (plug-ins
# exist only where they were registered)
BUILTIN = {c.name: c for c in (Saturation, FastDynamics, Delay, Convection, AmbientDrift,
                               PhaseResistance, LatentHeat, StressCoupling, AsymmetricWires,
                               SensorNonlinearity, FatigueDrift, CurrentLimit, SensorZero,
                               RecordStroke)}
for _cls in BUILTIN.values():
    register_effect(_cls)


def is_builtin(name: str) -> bool:
    """Return True if `name` is the package's own effect (not a plug-in, nor replaced by one)."""
    return name in BUILTIN and type(CATALOG.get(name)) is BUILTIN[name]


def get_effect(name: str) -> Effect:
    """Look `name` up in the catalog; the error lists the known effects."""
    try:
        return CATALOG[name]
    except KeyError:
        raise ValueError(f'unknown effect {name!r}; known: {", ".join(sorted(CATALOG))}') from None
