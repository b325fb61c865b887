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
Workbench engine: fit a model with a set of effects, and diagnose the missing effect.

fit_model: the paper's base model (per-wire first-order thermal dynamics, modified PI,
linear shaft/sensor map, wires sharing parameters) plus the chosen catalog effects,
identified by `core.identification` (free-run error; train on the first 70 % of time or
on even curves, validate on the rest).

diagnose: for every candidate effect not in the model, refit with it (same hysteresis
grid, warm-started from the base fit, so candidates compete on equal terms) and score the
held-out error. A candidate is significant only if
  1. held-out NRMSE falls by at least `min_improvement` (default 20 %),
  2. the Bayesian information criterion of the free-run residual on the training window
     agrees: BIC = n_eff ln(RSS / n) + k ln(n_eff) falls by more than `BIC_MARGIN` (10,
     "very strong" evidence), with n_eff the number of
     effectively independent samples (n divided by the residual's correlation length, the
     shorter of the base's and the candidate's), so serially correlated residuals cannot
     buy extra parameters cheaply; the candidate nests the base model, so a missing effect
     must fit the training window better by more than its extra parameters' worth (a
     held-out gain without that is luck of the split, not physics), and
  3. the effect itself carries the gain (the counterfactual): the base model refitted
     from where the candidate's refit ended (its hysteresis grid, weights and time
     constant) with the effect off must be worse on held-out data by at least
     `min_improvement` again; otherwise the gain came from the new grid or a re-tuned
     base (a fragile held-out window), not from the effect; and the training window must
     say so too: BIC against that refit must fall by more than `BIC_MARGIN` as in 2 (a
     new grid lets the free weights absorb a static distortion, so a sensor polynomial
     can fit training no better than the regridded base and still bend one held-out
     transient its way); and the gain must not come from a minority of the held-out
     motion only: where at least `MIN_MOVING_BLOCKS` of the `HELD_OUT_BLOCKS` blocks of
     held-out time each move over `MIN_COVERAGE` of the measured range, the median gain
     over those blocks (`moving_block_gains`) must not be below zero (a refit that moves
     the base's own parameters along a flat training valley can win a few blocks and lose
     the rest; a block that hardly moves is at the noise in both, its sign chance), and
  4. the fitted effect is large enough for the data to resolve (`Effect.unresolved`; a
     delay must exceed one sample period), and an effect on the heating law
     (`Effect.heating_law`) is not judged on training records that heat at one duty level
     (`levels.duty_levels`): there it fits about as well as any other heating law.
     A candidate that passes 1-3 but not 4 and gains more held out than a significant
     one, beyond `NEAR_TIE`, makes that one not significant too: the records cannot tell
     which of the two they show (`_yield_to_unresolved_rivals`).
When no candidate is significant, every one without an own grid is also refitted from
scratch and judged again: with two effects missing, the base can sit so far from the
data that a warm refit stays in its basin. The fit from scratch is judged where it trains to
within `NEAR_NOISE` times the noise, as `fit_dynamic` stops there, else the better training
fit of the two (`prefer_warm`): at the noise the warm refit, on the base grid, can train
better by fitting noise with that grid's extra elements, and its better training does not
say it holds out better. In the first pass, an own-grid candidate's best
warm trial and its best trial from scratch are chosen between by the same rule, except that
a warm trial training clearly better (by `NEAR_TIE`) stands (`warm_trial_stands`). A base that
already fits its training window to within the noise (`at_noise`) has no such basin: the
second pass is skipped. And when a
counterfactual (check 3) is itself a better fit of the base model, by `min_improvement`
in training RMSE and no worse held out (and, when an effect is named, better held out than
the named effect's model by `min_improvement`, or better than it in training by that bar and
no worse held out), the base's own fit sat in a poor minimum: the diagnosis starts again
from that fit (`better_base`, `Diagnosis.refitted` says so).
When still nothing is named and the base is short of the noise, check 1 is taken once more
on the typical held-out gain (`typical_pass`): the median over `HELD_OUT_BLOCKS` blocks
of held-out time, against the base and against the counterfactual. One excursion beyond the
trained travel can carry the whole window's RMSE while the candidate is better everywhere
else; checks 2 and 4 stay as they are, and so does the moving blocks' median of check 3.
Candidates are listed best first: significant ones by held-out improvement, then the
rest by held-out improvement; the first significant one is the missing effect. Two
significant candidates that retard the response (a delay and a lag,
`Effect.retards_response`) are ranked by their training BIC instead, where one fits the
training window clearly better (by `NEAR_TIE` in NRMSE; `_rank_retarders_by_training`):
the held-out window tells a dead time from a lag by chance where the base misfits it. When
several significant candidates come within `NEAR_TIE` (10 %) of the best gain, the data
can hardly tell them apart: they stay in held-out order and every explanation in the
group says so. When nothing is named because the base already predicts the held-out window
to the noise while its training window is misfitted, the candidate that fits training best
is reported as a lead to test elsewhere, not a name (`training_lead`).
"""
from dataclasses import dataclass, field, fields
from functools import partial
from itertools import chain
import time
from typing import Any, Callable, Iterator, Optional, Tuple

import numpy as np

from .branches import extrapolated_error_share, extrapolated_share, MOSTLY_EXTRAPOLATED
from .effects import CATALOG, Effect, get_effect, is_builtin
from .levels import duty_levels
from .parallel import available_cores, imap_on_cores
from .records import (loop_prior, record_strokes, referred_to_rest, stroke_scale,
                      untared_offsets, zeros)
from ..core import actuator as act
from ..core.datakinds import DynamicData, Split, StaticData
from ..core.hysteresis import PlayHysteresis
from ..core.identification import (fit_dynamic, fit_static, NEAR_NOISE,
                                   record_noise_rms, scores, SearchOptions)

MIN_IMPROVEMENT = 0.20
# BIC must fall by at least this much: "very strong" evidence on Kass & Raftery's (1995)
# scale; smaller falls come from training fits that hardly changed
BIC_MARGIN = 10.0
# candidate entry keys kept out of `Diagnosis.to_json` (objects, timings, internal checks)
INTERNAL_KEYS = ('fit', 'bic_change', 'seconds', 'base_refit', 'unresolved')
# significant candidates whose held-out gains are this close (relative to the best) explain
# the data about equally well: the explanation says so
NEAR_TIE = 0.10
# blocks of equal time the held-out window is cut into for the typical gain (`typical_gain`)
HELD_OUT_BLOCKS = 5
# fewest moving held-out blocks whose median gain must not be negative (check 3): a
# majority of the blocks
MIN_MOVING_BLOCKS = 3
# a candidate's refits from scratch are further starts beside its warm refit on the base
# fit's grid, which already is the best of the base's coarse grids: they search from the
# first coarse grid only
REFIT_SEARCH = SearchOptions(coarse_alternatives=())
# a pinned parameter's search interval, relative to its value (the optimiser needs one)
PIN_TOLERANCE = 1e-6
# a training error above this factor of the noise's leaves something to find there
# (three quarters of its mean square or more is misfit)
TRAINING_MISFIT = 2.0


@dataclass
class ModelFit:
    """A fitted model: effects included, parameters, scores and predictions."""

    effects: list
    kind: str
    values: dict
    train: Optional[dict]
    validation: Optional[dict]
    prediction: Optional[np.ndarray]      # model output at every sample of the data
    split: Optional[Split]                # train/validation division it was scored on
    n_parameters: int
    residual: Optional[np.ndarray]        # free-run residual on the training window
    params: Any = None                    # ActuatorParams (dynamic) or PlayHysteresis (static)
    signals: dict = field(default_factory=dict)
    grid: Optional[PlayHysteresis] = None
    # rig description for the model file: layout, position_unit, records (name, sensor zero
    # [position unit], role), sensor_zero_rule
    rig: dict = field(default_factory=dict)
    # {record name: the model fitted with that record left out} (`crossval.cross_validate`)
    folds: dict = field(default_factory=dict)
    # {record name: start offset [position unit]} of the records `load_fit` predicted from
    # their own start rest (an untared sensor)
    untared: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """YAML-able form: effects, kind, fitted values, model parameters, scores."""
        model = (self.params.to_dict() if hasattr(self.params, 'hysteresis')
                 else {'hysteresis': self.params.to_dict()})
        d = {'effects': list(self.effects), 'kind': self.kind,
             'parameters': {k: float(v) for k, v in self.values.items()},
             'model': model, 'scores': {'train': self.train, 'validation': self.validation}}
        d.update(self.rig)
        return d

    def shown_values(self) -> dict:
        """Return the fitted values as a person reads them, names in the rig's unit."""
        unit = self.rig.get('position_unit', '')
        return {act.name_in_unit(k, unit): float(v) for k, v in self.values.items()}

    def simulate(self, data: Any) -> np.ndarray:
        """Prediction of this fitted model at every sample of other data of its kind."""
        return data.simulate(self)[0]

    def inputs(self, data: DynamicData) -> tuple:
        """
        (duty_a, duty_b, ambient) the thermal model sees on dynamic data.

        Plug-in input transforms applied with the fitted values, constant ambient if none was
        measured.
        """
        amb = (data.ambient if data.ambient is not None
               else np.full(len(data), self.params.ambient_c))
        return _hooked_inputs(self.effects, data.duty_a, data.duty_b, amb, self.values)

    def trajectory(self, data: DynamicData) -> act.Trajectory:
        """Free-run `core.actuator.Trajectory` of this model on dynamic data."""
        da, db, amb = self.inputs(data)
        t = act.simulate(self.params, da, db, data.dt, ambient_c=amb)
        if 'sensor_zero' in self.effects:
            trained = list(self.rig.get('record_zeros', {}).values())
            t.position_rad = t.position_rad + zeros(
                data, float(np.median(trained)) if trained else None)
        return t


def _input_hooks(effects: list) -> list:
    """Effects (plug-ins) that transform the inputs."""
    return [get_effect(e) for e in effects
            if type(get_effect(e)).transform_inputs is not Effect.transform_inputs]


def _hooked_inputs(effects: list, duty_a: np.ndarray, duty_b: np.ndarray,
                   ambient: np.ndarray, values: dict) -> tuple:
    """Input after every plug-in transform, duties clipped to [0, 1]."""
    for eff in _input_hooks(effects):
        duty_a, duty_b, ambient = eff.transform_inputs(duty_a, duty_b, ambient, values)
    return np.clip(duty_a, 0.0, 1.0), np.clip(duty_b, 0.0, 1.0), ambient


def model_travel(params: Any, data: Any) -> Optional[float]:
    """
    Return the shaft travel of a dynamic model [position unit], None for curves.

    From all cold to one wire fully contracted, |g| (eq. step 4: φ = φ0 + g (y_a − s_b y_b),
    y in [0, 1]); from one end to the other on a pair, |g| (1 + s_b).
    """
    if data.kind != DynamicData.kind or not hasattr(params, 'stroke_rad'):
        return None
    pair = 0.0 if data.layout == 'single' else params.stroke_ratio_b
    return float(abs(params.stroke_rad) * (1.0 + pair))


def load_fit(d: dict, data: Any = None) -> ModelFit:
    """
    Return a ModelFit from `to_dict` output; scores and predictions are recomputed on `data`.

    A model without `sensor_zero` predicts a record read by an untared sensor (one that
    starts at rest off the model's rest by more than `records.UNTARED_SHARE` of the
    measured range, or of the model's travel when the records move less) from that
    record's own start rest: ŷ + z_k − z over its samples (`untared` holds the
    offsets z_k − z).
    """
    model = d.get('model', {})
    if set(model) == {'hysteresis'}:
        params = PlayHysteresis.from_dict(model['hysteresis'])
    else:
        params = act.ActuatorParams.from_dict(model)
    sc = d.get('scores', {})
    fit = ModelFit(list(d.get('effects', [])), d.get('kind', 'modified'),
                   dict(d.get('parameters', {})), sc.get('train'), sc.get('validation'),
                   None, None, 0, np.zeros(0), params)
    if isinstance(d.get('record_zeros'), dict):
        fit.rig['record_zeros'] = dict(d['record_zeros'])
    fit.rig.update({k: d[k] for k in ('layout', 'position_unit') if k in d})
    if data is not None:
        fit.prediction, fit.signals = data.simulate(fit)
        if data.kind == DynamicData.kind and 'sensor_zero' not in fit.effects:
            fit.untared = untared_offsets(data, fit.prediction,
                                          travel=model_travel(params, data) or 0.0)
            fit.prediction = referred_to_rest(data, fit.prediction, fit.untared)
        keep = data.scored_mask()
        fit.validation = scores(data.output[keep], fit.prediction[keep], data.span())
    return fit


def _kind(effects: list, kind: Optional[str]) -> str:
    """Hysteresis kind implied by the effects (an effect's `Effect.kind`, e.g. saturation)."""
    for e in effects:
        if get_effect(e).kind:
            return get_effect(e).kind
    return kind or 'modified'


def fit_model(data: Any, effects: tuple = (), kind: Optional[str] = None,
              progress: Optional[Callable] = None,
              base_fit: Optional[ModelFit] = None, pinned: Optional[dict] = None,
              search: Optional[SearchOptions] = None) -> ModelFit:
    """
    Fit the base model plus `effects` (catalog names) to dynamic or static data.

    kind: 'classical' or 'modified' PI base (default modified; an effect with a `kind`,
    saturation, forces its kind). base_fit: a previous ModelFit whose grid and values
    warm-start this one. pinned: {free parameter: value} held fixed in a dynamic fit
    (e.g. {'tau_s': 3.0} for a profile of the error over the time constant). search: how
    a dynamic fit searches from scratch (`identification.SearchOptions`); default the
    whole search, or with a `base_fit` `REFIT_SEARCH`.
    """
    effects = list(dict.fromkeys(effects))
    for e in effects:
        reason = data.unsupported(get_effect(e))
        if reason:
            raise ValueError(f'effect {e} cannot be fitted on this data: {reason}')
    kind = _kind(effects, kind)
    if progress:
        progress(0, 1, 'fit ' + ('+'.join(effects) or 'base'))
    if search is None:
        search = SearchOptions() if base_fit is None else REFIT_SEARCH
    fit = _FITTERS[data.kind](data, effects, kind, base_fit, pinned, search)
    if progress:
        progress(1, 1, 'fit done')
    return fit


def _fit_static(data: StaticData, effects: list, kind: str, base_fit: Optional[ModelFit],
                pinned: Optional[dict] = None, search: Optional[SearchOptions] = None
                ) -> ModelFit:
    """
    Fit a PI operator to curves: the paper's least-squares tuning (classical: plain LS).

    Curves have no free parameters besides the weights: nothing can be pinned, and the
    least squares have one minimum (`search` is not used).
    """
    if pinned:
        raise ValueError(f'static curves have no parameter {", ".join(pinned)} to pin')
    res = fit_static(data.input, data.output, data.curve, kind=kind,
                     nonneg=(kind == 'modified'))
    split = data.default_split()
    pred = data.flat(res.prediction)
    train = ~data.held_out(split)
    return ModelFit(effects, kind, {}, res.train, res.validation, pred, split,
                    int(np.count_nonzero(res.model.w)) + 2, pred[train] - data.output[train],
                    res.model)


# a held-out window whose measured range is below this fraction of the whole record set's
# range cannot tell models apart: its NRMSE is reported as uninformative
MIN_COVERAGE = 0.2


def rescore(data: Any, pred: np.ndarray, split: Split) -> tuple:
    """
    Return (train, validation) scores of `pred`, NRMSE over the whole record set's range.

    Each scores dict also has 'coverage': the range of the measured output in that part
    over the whole set's range, and 'informative': coverage >= MIN_COVERAGE.
    """
    train, val = data.split_masks(split)
    return part_scores(data, pred, train), part_scores(data, pred, val)


def part_scores(data: Any, pred: np.ndarray, mask: np.ndarray) -> Optional[dict]:
    """Return the scores of `pred` on the `mask` samples, with coverage (see `rescore`)."""
    if not mask.any():
        return None
    span = data.span()
    y = data.output[mask]
    s = scores(y, pred[mask], span)
    s['coverage'] = float(np.ptp(y) / span) if span > 0 else 0.0
    s['informative'] = bool(s['coverage'] >= MIN_COVERAGE)
    return s


def record_scores(data: DynamicData, pred: np.ndarray,
                  split: Optional[Split] = None, role: Optional[str] = None) -> list:
    """
    Return per-record scores of `pred` on joined `data`, NRMSE over the whole set's range.

    A list of {'data': name, 'role': 'train' | 'validation' | 'time split', 'scores':
    {'all': ...}}, one per record (whole record, rest gaps excluded); a record is held out
    when it starts at or after the split's start. role: every record's role instead (what
    the caller did with them, e.g. compared or left out in turn).
    """
    out = []
    keep = data.scored_mask()
    for name, a, b in data.segments or (('DATA', 0, len(data)),):
        mask = np.zeros(len(data), bool)
        mask[a:b] = True
        if role is not None:
            part = role
        elif len(data.segments) < 2:
            part = 'time split'
        else:
            part = 'validation' if split is not None and a >= split.start else 'train'
        out.append({'data': name, 'role': part,
                    'scores': {'all': part_scores(data, pred, mask & keep)}})
    return out


def _tared(data: DynamicData) -> tuple:
    """Return (`data` with each record's position relative to its start rest, the zeros)."""
    z = zeros(data)
    return DynamicData(data.time, data.duty_a, data.duty_b, data.position - z, data.ambient,
                       data.setpoint, data.position_unit, data.layout, data.segments,
                       data.scored, data.split), z


def _fit_dynamic(data: DynamicData, effects: list, kind: str,
                 base_fit: Optional[ModelFit], pinned: Optional[dict] = None,
                 search: SearchOptions = SearchOptions()) -> ModelFit:
    """
    Fit a dynamic record; a `sensor_zero` model is fitted on the tared positions.

    pinned: {free parameter: value} held fixed; search: `SearchOptions` (`fit_model`).
    """
    tare = 'sensor_zero' in effects
    # the residual is the same either way: the tare cancels in model − measured
    fit_data = _tared(data)[0] if tare else data
    strokes = None
    if 'record_stroke' in effects:
        fit_data, strokes, base_fit = _stroked(fit_data, effects, kind, base_fit, tare, pinned,
                                               search)
    fit = _fit_dynamic_raw(fit_data, effects, kind, base_fit, pinned, search)
    if strokes is not None:   # back to each record's own stroke: m0 + ρ (p − m0)
        m0 = zeros(fit_data)
        fit.prediction = m0 + stroke_scale(fit_data, strokes) * (fit.prediction - m0)
    if tare:
        fit.prediction = fit.prediction + zeros(data)
    if strokes is not None:   # the residual of the records as measured (BIC in diagnose)
        train = data.split_masks(fit.split)[0]
        fit.residual = fit.prediction[train] - data.position[train]
    fit.train, fit.validation = rescore(data, fit.prediction, fit.split)
    fit.rig = rig_info(data, fit.split)
    if strokes is not None:
        fit.rig['record_strokes'] = strokes
    return fit


def _stroked(data: DynamicData, effects: list, kind: str, base_fit: Optional[ModelFit],
             tared: bool, pinned: Optional[dict] = None,
             search: SearchOptions = SearchOptions()) -> tuple:
    """
    Return (`data` scaled to the median record's stroke, {record: ρ}, the pooled fit).

    ρ of each record from the pooled model (`effects` without `record_stroke`): the base
    fit's prediction when it is that model, else a fit of it; each record's departure
    from its start rest is divided by its ρ, m0 + (y − m0) / ρ (`records.record_strokes`).
    The pooled fit warm-starts the refit when no base fit is given.
    """
    pooled = [e for e in effects if e != 'record_stroke']
    if (base_fit is not None and list(base_fit.effects) == pooled
            and base_fit.prediction is not None and len(base_fit.prediction) == len(data)):
        pred = base_fit.prediction - (zeros(data) if tared else 0.0)
    else:
        base_fit = _fit_dynamic_raw(data, pooled, kind, base_fit, pinned, search)
        pred = base_fit.prediction
    strokes = record_strokes(data, pred)
    m0 = zeros(data)
    y = m0 + (data.position - m0) / stroke_scale(data, strokes)
    return (DynamicData(data.time, data.duty_a, data.duty_b, y, data.ambient, data.setpoint,
                        data.position_unit, data.layout, data.segments, data.scored,
                        data.split), strokes, base_fit)


_FITTERS = {StaticData.kind: _fit_static, DynamicData.kind: _fit_dynamic}


def rig_info(data: DynamicData, split: Optional[Split] = None) -> dict:
    """
    Return the rig keys of a model file fitted on dynamic `data`.

    layout, position_unit and record_zeros: {record: its start rest [position unit]}
    (the sensor zero `sensor_zero` refers each record to), record_roles {record: train |
    validation | time split}.
    """
    z = zeros(data)
    segs = data.segments or (('DATA', 0, len(data)),)
    roles = {r['data']: r['role'] for r in record_scores(data, np.zeros(len(data)), split)}
    return {'layout': data.layout, 'position_unit': data.position_unit,
            'record_zeros': {name: float(z[a]) for name, a, _ in segs},
            'record_roles': roles}


def _fit_dynamic_raw(data: DynamicData, effects: list, kind: str,
                     base_fit: Optional[ModelFit], pinned: Optional[dict] = None,
                     search: SearchOptions = SearchOptions()) -> ModelFit:
    """
    Fit the effects' free parameters: warm from `base_fit`, its alternative starts.

    An `own_grid` effect new to `base_fit` is also fitted from scratch from the same
    starts; of the best warm trial and the best from scratch (lowest training RMSE each),
    `warm_trial_stands` chooses. pinned: {free parameter: value} held within PIN_TOLERANCE of
    value; search: how each start searches from scratch.
    """
    pinned = pinned or {}
    # sorted: a negative value's lower bound is v (1 + tolerance)
    free = {k: tuple(sorted((v * (1.0 - PIN_TOLERANCE), v * (1.0 + PIN_TOLERANCE)))) + (v,)
            for k, v in pinned.items()}
    start = dict(base_fit.values) if base_fit else {}
    start.update(pinned)
    alternatives = []
    params = base_fit.params if base_fit is not None else act.ActuatorParams()
    for e in effects:
        eff = get_effect(e)
        free.update({k: b for k, b in eff.bounds(params).items() if k not in pinned})
        for k, v in eff.start_values(data).items():
            start.setdefault(k, v)
        if base_fit is None or e not in base_fit.effects:
            alternatives += eff.alternative_starts(data)
    hook = partial(_hooked_inputs, effects) if _input_hooks(effects) else None
    same_grid = base_fit is not None and base_fit.kind == kind and base_fit.grid is not None
    # training data that never cools back leaves the descending branch to the datasheet loop
    loop_ratio = loop_prior(data)
    trials = [(dict(start, **alt), same_grid, {}) for alt in [{}] + alternatives]
    # from scratch: also without the base's time constant, so the coarse stage's
    # multi-start over τ runs; the effect moves τ (latent heat slows the transformation),
    # and a search from the base's τ ends in a basin that rounding decides
    scratch = {k: v for k, v in start.items() if k != 'tau_s' or k in pinned}
    for eff in map(get_effect, effects):
        if same_grid and eff.name not in base_fit.effects and eff.own_grid:
            # also from scratch, on a grid of its own, from each start a fresh fit tries:
            # the basin a start reaches on the base grid is not the one it reaches there
            for alt in [{}] + eff.alternative_starts(data):
                trials.append((dict(scratch, **eff.scratch_start(params), **alt), False,
                               {k: b for k, b in eff.scratch_bounds(params).items()
                                if k not in pinned}))
    best = {}
    for trial_start, warm, bounds in trials:
        trial = fit_dynamic(data, free=dict(free, **bounds), kind=kind,
                            grid=base_fit.grid if warm else None,
                            start=trial_start, input_hook=hook,
                            ref=base_fit.params.hysteresis if warm else None,
                            options=search, loop_ratio=loop_ratio)
        if warm not in best or trial.train['rmse'] < best[warm].train['rmse']:
            best[warm] = trial
    res = best.get(False, best.get(True))
    if True in best and False in best and warm_trial_stands(data, best[True], best[False]):
        res = best[True]
    train = data.split_masks(res.split)[0]
    resid = res.prediction[train] - data.position[train]
    t = res.trajectory
    return ModelFit(effects, kind, res.free, res.train, res.validation, res.prediction,
                    res.split, res.n_parameters, resid, res.params,
                    {'theta_a': t.theta_a_c, 'theta_b': t.theta_b_c, 'y_a': t.y_a,
                     'y_b': t.y_b, 'time': data.time}, res.grid)


def correlation_length(residual: np.ndarray) -> int:
    """Lag (samples) where the residual's autocorrelation first drops below 1/e (>= 1)."""
    r = np.asarray(residual, float) - np.mean(residual)
    if len(r) < 4 or not np.any(r):
        return 1
    f = np.fft.rfft(r, 2 * len(r))
    acf = np.fft.irfft(f * np.conj(f))[: len(r)]
    acf /= acf[0]
    below = np.flatnonzero(acf < np.exp(-1))
    return int(below[0]) if below.size else len(r)


def bic(residual: np.ndarray, n_parameters: int, n_eff: float) -> float:
    """BIC = n_eff ln(RSS/n) + k ln(n_eff) of a residual with k parameters."""
    r = np.asarray(residual, float)
    return n_eff * np.log(np.mean(r ** 2) + 1e-300) + n_parameters * np.log(max(n_eff, 2))


def bic_gain(base: ModelFit, fit: ModelFit, base_length: Optional[int] = None) -> float:
    """
    Return BIC(fit) − BIC(base) on their training residuals (negative: `fit` is better).

    Both are counted on n_eff = n / L effectively independent samples, L the shorter
    correlation length of the two residuals (`base_length`: the base's, if known). A slow
    effect the base lacks stretches the base residual's correlation over the whole record
    (a drift: 16 750 samples at 1694 samples of correlation count as 9.9), while the
    residual of the model with the effect shows the noise's own correlation (2 samples).
    """
    length = min(base_length or correlation_length(base.residual),
                 correlation_length(fit.residual))
    n_eff = max(len(base.residual) / length, 2.0)
    return (bic(fit.residual, _free_count(fit), n_eff)
            - bic(base.residual, _free_count(base), n_eff))


def _free_count(fit: ModelFit) -> int:
    """Return the effects' parameter count; an effect that sets the PI kind counts one."""
    return sum(len(get_effect(e).parameters) + (1 if get_effect(e).kind else 0)
               for e in fit.effects)


@dataclass
class Diagnosis:
    """Result of `diagnose`."""

    baseline: ModelFit
    candidates: list
    missing_effect: object
    # why the baseline is not the model diagnose was given: a better fit of it was found
    refitted: str = ''
    # seconds of the candidate refits judged against the base before it was refitted
    earlier_seconds: float = 0.0
    # the NRMSE the measurement noise alone gives (`noise_floor`), None if not known
    noise_floor_nrmse: Optional[float] = None
    # what fits a training window the held-out one cannot judge (`training_lead`), or None
    training_lead: Optional[dict] = None

    def to_json(self) -> dict:
        """Return the `sma-model diagnose --json` document."""
        base = {'effects': list(self.baseline.effects),
                'validation_nrmse': self.baseline.validation['nrmse'],
                'train_nrmse': self.baseline.train['nrmse']}
        if self.noise_floor_nrmse is not None:
            base['noise_floor_nrmse'] = self.noise_floor_nrmse
        if self.refitted:
            base['refitted'] = self.refitted
        doc = {'baseline': base,
               'candidates': [candidate_json(c) for c in self.candidates],
               'missing_effect': self.missing_effect}
        if self.training_lead:
            doc['training_lead'] = self.training_lead
        return doc


def candidate_json(entry: dict) -> dict:
    """Return a candidate entry's JSON form: 'not_resolved' says why check 4 refused it."""
    out = {k: v for k, v in entry.items() if k not in INTERNAL_KEYS}
    if entry.get('unresolved'):
        out['not_resolved'] = entry['unresolved'][0]
    return out


def diagnose(data: Any, base: Optional[ModelFit] = None, candidates: Optional[list] = None,
             progress: Optional[Callable] = None, min_improvement: float = MIN_IMPROVEMENT,
             kind: Optional[str] = None, jobs: int = 1,
             mapper: Optional[Callable] = None, rebase: int = 1) -> 'Diagnosis':
    """
    Rank candidate effects by held-out error reduction; name the missing one (or None).

    base: a ModelFit (or None: fit the paper's base model, `kind` PI). candidates: effect
    names (default: every catalog effect not in the base). jobs: processes for the
    candidate refits (independent fits; 0 = every core). mapper(tasks) -> the
    `judge_candidate` entries of the tasks, in any order: runs the refits elsewhere (the
    batch sends them to its Dask cluster); default: a pool of `jobs` processes. Plug-in
    effects are refitted in this process, since a worker would not have them registered.
    rebase: how many times a better fit of the base itself, found by a counterfactual
    (`better_base`), may replace it and the diagnosis start again from there.
    """
    if base is None:
        base = fit_model(data, (), kind=kind)
    tasks = candidate_tasks(data, base, candidates, min_improvement)
    names = [t[2] for t in tasks]
    builtin = all(is_builtin(e) for e in base.effects)

    def poolable(name: str) -> bool:
        """Return True for a costly refit (worth a process) of an effect every process has."""
        return (builtin and is_builtin(name) and data.costly_fit
                and data.unsupported(get_effect(name)) is None)

    def judged(tasks: list, stage: str) -> dict:
        """Return {name: entry} of `tasks`, the costly ones on the pool or `mapper`."""
        pooled, local = [], []
        for t in tasks:
            (pooled if poolable(t[2]) else local).append(t)
        # the slowest refits (a second one from scratch) first, so no core idles at the end
        pooled.sort(key=lambda t: not get_effect(t[2]).own_grid)
        out = {}
        if progress:
            progress(0, len(tasks), stage)
        for entry in chain(map(judge_candidate, local),
                           (mapper or partial(_judge_on_cores, jobs))(pooled)):
            out[entry['effect']] = entry
            if progress:
                progress(len(out), len(tasks), entry['effect'])
        return out

    entries = judged(tasks, 'candidates')
    diag = rank_candidates(base, list(entries.values()))
    # nothing named: a base far from the data (another effect missing too) can hold a warm
    # refit in its basin, so each candidate is also refitted from scratch and judged again
    if (diag.missing_effect is None and isinstance(data, DynamicData)
            and not at_noise(base, data, min_improvement)):
        rescue = [t + (entries[t[2]]['fit'],) for t in tasks
                  if 'fit' in entries[t[2]] and not get_effect(t[2]).own_grid]
        if rescue:
            entries.update(judged(rescue, 'candidates from scratch'))
            diag = rank_candidates(base, list(entries.values()))
    if (diag.missing_effect is None and isinstance(data, DynamicData)
            and not at_noise(base, data, min_improvement)):
        named = typical_pass(data, base, list(entries.values()), min_improvement)
        if named:
            diag = rank_candidates(base, list(entries.values()), 'typical_gain')
    better = (better_base(base, list(entries.values()), min_improvement,
                          named=entries.get(diag.missing_effect))
              if rebase > 0 else None)
    if better is not None:
        refit, why = better
        diag = diagnose(data, refit, candidates, progress, min_improvement, kind, jobs, mapper,
                        rebase - 1)
        diag.refitted = '; '.join(filter(None, (why, diag.refitted)))
        diag.earlier_seconds += sum(c.get('seconds', 0.0) for c in entries.values())
    diag.noise_floor_nrmse = noise_floor(data)
    diag.training_lead = training_lead(data, diag, min_improvement)
    if progress:
        progress(len(names), len(names), 'done')
    return diag


def noise_floor(data: Any) -> Optional[float]:
    """
    Return the NRMSE a perfect model would score on `data`: its measurement noise.

    σ / span, σ from `identification.record_noise_rms` over each record's measured positions, span
    the range measured over the whole set (the NRMSE's scale); None for static curves,
    whose points are not a time series.
    """
    span = data.span()
    if not isinstance(data, DynamicData) or span <= 0:
        return None
    return record_noise_rms(data) / span


def at_noise(base: ModelFit, data: DynamicData, min_improvement: float) -> bool:
    """
    Return True when the base fits its training window to within the measurement noise.

    True when training NRMSE <= noise floor / (1 − min_improvement): no refit, from
    anywhere, can fit that window by `min_improvement` better without fitting the noise,
    so there is no basin for a refit from scratch to escape.
    """
    floor = noise_floor(data)
    return floor is not None and bool(base.train['nrmse'] * (1.0 - min_improvement) <= floor)


def held_out_cannot_judge(held_out: float, train: float) -> bool:
    """
    Return True when the held-out window is at the noise and the training window is not.

    held_out, train: a model's held-out and training NRMSE over the noise floor's
    (`noise_floor`): within `NEAR_NOISE` held out and beyond `TRAINING_MISFIT` in
    training, the held-out window does not show what the training window lacks.
    """
    return held_out <= NEAR_NOISE and train > TRAINING_MISFIT


def training_lead(data: Any, diag: 'Diagnosis', min_improvement: float) -> Optional[dict]:
    """
    Return the candidate that best fits a training window the held-out one cannot judge.

    When nothing is named, the base predicts the held-out window to within `NEAR_NOISE`
    times the noise floor (`Diagnosis.noise_floor_nrmse`) and fits its training window
    worse than `TRAINING_MISFIT` times it, no candidate can gain held out (check 1), yet
    the training window shows something missing. The lead is, of the resolved candidates
    (check 4) whose refit fits the training window by `min_improvement` better in NRMSE,
    beats the base on BIC by `BIC_MARGIN` (check 2) and still holds out within
    `NEAR_NOISE` of the noise, the one with the largest BIC fall: a hint to test on a
    record that shows it, not a name. data: the records diagnosed (for check 4). Returns
    {'effect', 'train_nrmse', 'validation_nrmse', 'bic_change'} or None.
    """
    base, floor = diag.baseline, diag.noise_floor_nrmse
    if (diag.missing_effect is not None or not floor or base.validation is None
            or not held_out_cannot_judge(base.validation['nrmse'] / floor,
                                         base.train['nrmse'] / floor)):
        return None
    leads = [c for c in diag.candidates if 'fit' in c
             and c['bic_change'] < -BIC_MARGIN
             and c['fit'].train['nrmse'] <= (1.0 - min_improvement) * base.train['nrmse']
             and c['fit'].validation['nrmse'] <= NEAR_NOISE * floor
             and unresolved_by(get_effect(c['effect']), c['fit'].values, data, base) is None]
    if not leads:
        return None
    best = min(leads, key=lambda c: c['bic_change'])
    return {'effect': best['effect'], 'train_nrmse': best['fit'].train['nrmse'],
            'validation_nrmse': best['fit'].validation['nrmse'],
            'bic_change': best['bic_change']}


def held_out_block_rmse(data: DynamicData, reference: ModelFit,
                        fit: ModelFit) -> Optional[np.ndarray]:
    """
    Return the RMSE [output unit] of `reference` (row 0) and `fit` (row 1) in each block.

    The held-out samples (of the reference's split) are cut into `HELD_OUT_BLOCKS` blocks of
    equal count; column j holds √(mean((ŷ − y)²)) over block j. None when there are fewer
    held-out samples than blocks or a prediction is missing.
    """
    if reference.split is None or reference.prediction is None or fit.prediction is None:
        return None
    blocks = held_out_blocks(data, reference.split)
    if len(blocks[-1]) == 0:
        return None
    y = data.output
    return np.array([[np.sqrt(np.mean((model.prediction[block] - y[block]) ** 2))
                      for block in blocks]
                     for model in (reference, fit)])


def held_out_blocks(data: DynamicData, split: Split) -> list:
    """Return the sample indices of `split`'s held-out window in `HELD_OUT_BLOCKS` blocks."""
    _, val = data.split_masks(split)
    return np.array_split(np.flatnonzero(val), HELD_OUT_BLOCKS)


def typical_gain(data: DynamicData, reference: ModelFit, fit: ModelFit) -> Optional[float]:
    """
    Return the median over held-out time blocks of 1 − RMSE(fit) / RMSE(reference).

    The blocks are those of `held_out_block_rmse`. The median says how much better `fit`
    is for most of the held-out time: one excursion beyond the travel training saw can
    carry the whole window's RMSE, and after it the hysteresis state of every model stays
    off for a while. None when there are no blocks or a block's reference error is 0.
    """
    rmse = held_out_block_rmse(data, reference, fit)
    if rmse is None or np.any(rmse[0] <= 0):
        return None
    return float(np.median(1.0 - rmse[1] / rmse[0]))


def moving_block_gains(data: DynamicData, reference: ModelFit,
                       fit: ModelFit) -> Optional[np.ndarray]:
    """
    Return 1 − RMSE(fit) / RMSE(reference) in each held-out block that moves.

    The blocks are those of `held_out_block_rmse`; a block moves when the measured output
    in it covers at least `MIN_COVERAGE` of the range measured over the whole set
    (`data.span()`, the NRMSE's scale), as a validation window must to be informative.
    None when there are no blocks or a moving block's reference error is 0.
    """
    rmse = held_out_block_rmse(data, reference, fit)
    if rmse is None:
        return None
    moving = np.array([np.ptp(data.output[b]) >= MIN_COVERAGE * data.span()
                       for b in held_out_blocks(data, reference.split)])
    if np.any(rmse[0][moving] <= 0):
        return None
    return 1.0 - rmse[1][moving] / rmse[0][moving]


def few_moving_stretches(data: Any, reference: ModelFit,
                         fit: ModelFit) -> Optional[np.ndarray]:
    """
    Return the moving blocks' gains when a few stretches carry `fit`'s gain, else None.

    Check 3's last part: where at least `MIN_MOVING_BLOCKS` held-out blocks move
    (`moving_block_gains`), their median gain over `reference` must not be below zero.
    """
    moving = (moving_block_gains(data, reference, fit)
              if isinstance(data, DynamicData) else None)
    if moving is None or len(moving) < MIN_MOVING_BLOCKS or np.median(moving) >= 0.0:
        return None
    return moving


def typical_pass(data: DynamicData, base: ModelFit, entries: list,
                 min_improvement: float) -> list:
    """
    Judge entries again on their typical held-out gain; return the names made significant.

    A candidate whose refit passes the BIC check (2) and is resolved (4) is significant
    when its typical gain (`typical_gain`) over the base is at least `min_improvement`, and
    so is its typical gain over the counterfactual (3: the base refitted on its grid without
    it), whose training fit it beats on BIC as in 3, and a few moving stretches do not
    carry it (`few_moving_stretches`, as in 3: blocks that hardly move can lift the median
    of all five). Each such entry gets 'typical_gain' and says so in its explanation.
    """
    named = []
    for c in entries:
        fit = c.get('fit')
        if (fit is None or c['significant'] or c.get('rival')
                or c['bic_change'] >= -BIC_MARGIN):
            continue
        eff = get_effect(c['effect'])
        gain = typical_gain(data, base, fit)
        if (gain is None or gain < min_improvement or unresolved_by(eff, fit.values, data, base)
                or few_moving_stretches(data, base, fit) is not None):
            continue
        off = c.get('base_refit') or _regridded_base(data, base, fit, eff)
        carried = None if off is None else typical_gain(data, off, fit)
        if off is not None and (carried is None or carried < min_improvement
                                or bic_gain(off, fit) >= -BIC_MARGIN):
            continue
        c.update(significant=True, typical_gain=gain)
        c['explanation'] += (
            f' Significant by its typical held-out gain: the median over {HELD_OUT_BLOCKS} '
            f'blocks of held-out time is {100 * gain:+.0f} % against the base'
            + ('' if carried is None else
               f' and {100 * carried:+.0f} % against the base refitted on its grid')
            + f' (whole window {100 * c["improvement"]:+.0f} %).')
        named.append(c['effect'])
    return named


def better_base(base: ModelFit, entries: list, min_improvement: float,
                named: Optional[dict] = None) -> Optional[tuple]:
    """
    Return (a better fit of the base model, why) from the candidates' counterfactuals, or None.

    A counterfactual refits the base model itself (no effect added) from where a
    candidate's refit ended. When that fits the training window better by at least
    `min_improvement` (training RMSE, the fit's own objective) and is no worse held out, the
    base's own fit sat in a poor minimum: with two effects missing, a fit that lacks both can
    end far from its best. Candidates judged against such a base are judged against the
    wrong reference, so diagnose starts again from the better fit. named: the entry of the
    effect named against the base; it has beaten its own counterfactual, so the better fit
    must also beat it held out by `min_improvement`, the bar the effect cleared to be named
    (the base without any effect predicting clearly better than the named effect: the gain
    was the base's poor minimum, not the effect; near the noise floor a smaller held-out
    difference is chance), or else fit training better than the effect's model by that bar
    and hold out no worse (`outfits_named`).
    """
    refits = [(c['base_refit'], c['effect']) for c in entries if c.get('base_refit') is not None]
    if not refits:
        return None
    refit, name = min(refits, key=lambda r: r[0].train['rmse'])
    t0, t1 = base.train['rmse'], refit.train['rmse']
    v0, v1 = base.validation['nrmse'], refit.validation['nrmse']
    if t1 > (1.0 - min_improvement) * t0 or v1 > v0:
        return None
    if named is not None and not (v1 < (1.0 - min_improvement) * named.get(
            'validation_nrmse', -np.inf) or outfits_named(refit, named, min_improvement)):
        return None
    return refit, (f'the base model refitted from where the {name} refit ended fits better '
                   f'(training NRMSE {100 * base.train["nrmse"]:.2f} % -> '
                   f'{100 * refit.train["nrmse"]:.2f} %, held-out {100 * v0:.2f} % -> '
                   f'{100 * v1:.2f} %): diagnosed from that fit')


def outfits_named(refit: ModelFit, named: dict, min_improvement: float) -> bool:
    """
    Return whether a fit of the base beats the named effect's model in training and held out.

    The effect's model nests the base (the effect at its neutral value is the base), so its
    training RMSE can only be above a base fit's when its own search stopped short. A base
    refit whose training RMSE is below (1 − min_improvement) times the effect model's, and
    whose held-out NRMSE is no worse, shows that the effect was named from a poor minimum:
    its gain was measured against a base far from the base's best.
    """
    fit = named.get('fit')
    if fit is None or named.get('validation_nrmse') is None:
        return False
    return (refit.train['rmse'] < (1.0 - min_improvement) * fit.train['rmse']
            and refit.validation['nrmse'] <= named['validation_nrmse'])


def _judge_on_cores(jobs: int, tasks: list) -> Iterator[dict]:
    """Yield the `judge_candidate` entries of `tasks`, on `jobs` processes (0: every core)."""
    workers = min(jobs or available_cores(), len(tasks))
    if workers <= 1:
        yield from map(judge_candidate, tasks)
    else:
        yield from (entry for _, entry in imap_on_cores(judge_candidate, tasks, workers))


def candidate_tasks(data: Any, base: ModelFit, candidates: Optional[list] = None,
                    min_improvement: float = MIN_IMPROVEMENT) -> list:
    """
    One `judge_candidate` task per candidate effect not already in `base`.

    A task is (data, base, name, base_length, min_improvement): base_length is the
    correlation length (samples) of the base's training residual, computed once here.
    """
    names = [n for n in (candidates or CATALOG) if n not in base.effects]
    base_length = correlation_length(base.residual)
    return [(data, base, name, base_length, min_improvement) for name in names]


def rank_candidates(base: ModelFit, entries: list, gain: str = 'improvement') -> 'Diagnosis':
    """
    Return the `Diagnosis` of judged entries: significant first, by held-out gain.

    gain: the entry key the significant ones are ranked by ('typical_gain' after
    `typical_pass`); the others by their whole-window improvement. A significant entry
    that an unresolved candidate clearly outgains held out is made not significant first
    (`_yield_to_unresolved_rivals`); the first significant entry left is the missing effect.
    """
    def key(c: dict) -> tuple:
        value = c.get(gain) if c['significant'] else c['improvement']
        return c['significant'], -np.inf if value is None else value

    for c in entries:
        if c['significant']:
            _yield_to_unresolved_rivals(c, entries)
    out = sorted(entries, key=key, reverse=True)
    _rank_retarders_by_training(out, gain)
    best = next((c for c in out if c['significant']), None)
    _flag_near_ties(out, gain)
    return Diagnosis(base, out, None if best is None else best['effect'])


def _rank_retarders_by_training(ranked: list, gain: str = 'improvement') -> None:
    """
    Put first, in their places in `ranked`, the significant retarder that fits training best.

    A dead time d and a first-order lag of about d (`Effect.retards_response`) shift the
    response to the duty alike to first order in ω d. Where the base misfits the held-out
    window, which of the two fits that window better is chance; the training window, over
    twice as long, tells them apart by likelihood: the BIC change against the same base
    (each adds one parameter), the lower one first. It decides only where it clearly does,
    its training NRMSE at least `NEAR_TIE` below the held-out leader's; where the two fit
    training about alike, the held-out order stands.
    """
    places = [i for i, c in enumerate(ranked)
              if c['significant'] and getattr(CATALOG.get(c['effect']), 'retards_response',
                                              False)]
    group = [ranked[i] for i in places]
    best = min(group, key=lambda c: c['bic_change'], default=None)
    if best is None or best is group[0]:
        return
    other = group[0]
    fits = [c['fit'].train['nrmse'] for c in (best, other)]
    if fits[0] > (1.0 - NEAR_TIE) * fits[1]:
        return
    said = f' Ranked before {other["effect"]}'
    if said not in best['explanation']:
        best['explanation'] += (
            f'{said}, which gains more held out ({100 * other[gain]:+.0f} % against '
            f'{100 * best[gain]:+.0f} %): it fits the training window clearly better '
            f'(NRMSE {100 * fits[0]:.2f} % against {100 * fits[1]:.2f} %, BIC change '
            f'{best["bic_change"]:+.1f} against {other["bic_change"]:+.1f}), and a dead time '
            'and a lag shift the response alike, so the longer window tells them apart.')
    group.remove(best)
    for i, c in zip(places, [best] + group):
        ranked[i] = c


def _yield_to_unresolved_rivals(entry: dict, entries: list) -> None:
    """
    Make the significant `entry` not significant when an unresolved rival clearly gains more.

    A candidate that passed every check but resolution (`unresolved_by`: a delay below one
    sample, a lag below half a sample, a heating law on records at one duty level) and
    gains more held out than `entry` is another explanation of the same data that these
    records cannot confirm: at 10 Hz a 50 ms delay and a 0.1 s lag shift the sampled
    response alike. When `entry` comes within `NEAR_TIE` of its gain, the data barely
    separate the two and the resolved one stays named, its explanation naming the rival;
    when the rival gains clearly more, naming `entry` would be a guess, so it is made not
    significant ('rival' holds the rival's name).
    """
    # both gains are set: entry is significant, a rival passed check 1
    rivals = [c for c in entries if c.get('unresolved') and c is not entry
              and c['improvement'] > entry['improvement']]
    if not rivals:
        return
    c = max(rivals, key=lambda r: r['improvement'])
    reason, remedy = c['unresolved']
    clearly = entry['improvement'] < (1.0 - NEAR_TIE) * c['improvement']
    said = f" {c['effect']} fits the held-out window better"
    if said in entry['explanation']:
        return   # ranked again after a later pass
    entry['explanation'] += (
        (' Not named:' if clearly else '') + said
        + f" ({100 * c['improvement']:+.0f} % against {100 * entry['improvement']:+.0f} %) "
        f'but is not resolved ({reason}): {remedy} to separate them.')
    if clearly:
        entry.update(significant=False, rival=c['effect'])


def diagnose_rounds(data: Any, base: ModelFit, rounds: int, **kw: Any) -> tuple:
    """
    Diagnose, add the missing effect, refit, diagnose again: up to `rounds` rounds.

    Stops when nothing is significant. The refit of a round is the named candidate's own
    refit (base grid, warm start, also from scratch for `own_grid` effects). Returns
    (the Diagnosis of every round, [{'added': name, 'validation_nrmse': x}, ...], the
    final ModelFit). A round whose diagnosis refitted its base (`Diagnosis.refitted`) also
    has 'refitted_base_nrmse', the held-out NRMSE of that better base fit; after a last
    round that names nothing the final fit is its base, refitted or not. With two effects
    or more added, each is judged again next to the others (`prune_effects`); one that is
    no longer significant leaves the final fit, and its round gets 'removed': True and
    'validation_nrmse_without', the held-out NRMSE once it is removed. kw:
    passed to `diagnose` (candidates, progress, jobs, ...).
    """
    diags, added = [], []
    for _ in range(max(int(rounds), 1)):
        diag = diagnose(data, base=base, **kw)
        diags.append(diag)
        base = diag.baseline
        best = next((c for c in diag.candidates if c['effect'] == diag.missing_effect), None)
        if best is None:
            break
        added.append({'added': best['effect'],
                      'validation_nrmse': best['fit'].validation['nrmse']})
        if diag.refitted:
            added[-1]['refitted_base_nrmse'] = base.validation['nrmse']
        base = best['fit']
    if len(added) >= 2:
        base, removed = prune_effects(data, base, **kw)
        for r in removed:
            entry = next(a for a in added if a['added'] == r['removed'])
            entry.update(removed=True, validation_nrmse_without=r['validation_nrmse'])
    return diags, added, base


def prune_effects(data: Any, fit: ModelFit, **kw: Any) -> tuple:
    """
    Drop the named effects the others make redundant; return (the fit, [{'removed', ...}]).

    The rounds add one effect at a time, each judged against the model before it, and a
    later effect can take over what an earlier one stood in for (a current limit for an
    unmodelled lag). So each effect is judged again as if it were the last one missing:
    the model with the others, refitted warm from `fit`, is diagnosed with that effect
    as the only candidate (all four checks of `diagnose`). One that is not named again is
    removed, and the check starts over on the smaller model. Each entry has the removed
    'removed' effect and the held-out 'validation_nrmse' of the model without it.
    kw: passed to `diagnose` (progress, jobs; the candidates are the fit's effects).
    """
    kw = {k: v for k, v in kw.items() if k != 'candidates'}
    removed = []
    while len(fit.effects) >= 2:
        for name in fit.effects:
            rest = tuple(e for e in fit.effects if e != name)
            kind = None if get_effect(name).kind else fit.kind
            diag = diagnose(data, base=fit_model(data, rest, kind=kind, base_fit=fit),
                            candidates=[name], **kw)
            if diag.missing_effect != name:
                fit = diag.baseline
                removed.append({'removed': name, 'validation_nrmse': fit.validation['nrmse']})
                break
        else:
            break
    return fit, removed


def judge_candidate(task: tuple) -> dict:
    """
    Refit with one candidate effect and judge it (see the module docstring).

    Returns the candidate's entry of `Diagnosis.candidates` (module level: runs in worker
    processes).
    """
    started = time.perf_counter()
    entry = _judge(*task)
    entry['seconds'] = time.perf_counter() - started
    return entry


def _judge(data: Any, base: ModelFit, name: str, base_length: int,
           min_improvement: float, warm: Optional[ModelFit] = None) -> dict:
    """
    Return the candidate entry of `name` (without its time).

    warm: its refit warm from the base, already made; then it is also refitted from
    scratch and one of the two is judged (`prefer_warm`).
    """
    eff = get_effect(name)
    reason = data.unsupported(eff)
    if reason is None and eff.kind is not None and base.kind == eff.kind:
        reason = f'the base model already is {eff.kind} PI'
    if reason:
        entry = {'effect': name, 'validation_nrmse': None, 'train_nrmse': None,
                 'improvement': None, 'significant': False,
                 'explanation': f'not applicable: {reason}'}
        lacking = eff.applicable(data)
        if lacking:
            entry['data_lack'] = lacking     # a signal or records the user could add
        return entry
    effects = list(base.effects) + [name]
    try:
        fit = fit_model(data, effects, kind=base.kind, base_fit=base if warm is None else None,
                        search=REFIT_SEARCH)
        if warm is not None and prefer_warm(data, warm, fit):
            fit = warm
    except ValueError as err:
        return {'effect': name, 'validation_nrmse': None, 'train_nrmse': None,
                'improvement': None, 'significant': False,
                'explanation': f'fit failed: {err}'}
    v0, v1 = base.validation['nrmse'], fit.validation['nrmse']
    gain = (v0 - v1) / v0 if v0 > 0 else 0.0
    bic_change = bic_gain(base, fit, base_length)
    evident = gain >= min_improvement and bic_change < -BIC_MARGIN
    # the counterfactual costs a fit, so it runs only where the first two checks pass
    base_refit = _regridded_base(data, base, fit, eff) if evident else None
    v_off = None if base_refit is None else base_refit.validation['nrmse']
    # the base refitted where the candidate's refit ended, without the effect, must fall
    # short of it by at least the improvement asked of the effect, held out and in training
    carried = v_off is None or v_off <= 0 or (v_off - v1) / v_off >= min_improvement
    bic_off = None if base_refit is None else bic_gain(base_refit, fit)
    carried = carried and (bic_off is None or bic_off < -BIC_MARGIN)
    few = few_moving_stretches(data, base, fit) if evident and carried else None
    spread = few is None
    unresolved = unresolved_by(eff, fit.values, data, base)
    significant = bool(evident and carried and spread and unresolved is None)
    checks = ('' if v_off is None else
              f", {100 * v_off:.2f} % for the base refitted on the candidate's grid"
              f' (training NRMSE {100 * base_refit.train["nrmse"]:.2f} %, BIC change '
              f'{bic_off:+.1f} against it)')
    if warm is not None and fit is not warm:
        checks += (', refitted from scratch (the warm refit fitted the training window worse)'
                   if fit.train['rmse'] < warm.train['rmse'] else
                   ', refitted from scratch (it fits the training window to the noise; the '
                   'warm refit only fits the noise better)')
    if evident and not carried:
        checks += ('; not significant: the base refitted on the same grid does about as '
                   'well, so the grid, not the effect, carries the gain')
    if not spread:
        checks += (f'; not significant: {np.sum(few < 0)} of the {len(few)} held-out '
                   f'blocks that move get worse (median {100 * np.median(few):+.1f} %), '
                   'so a few stretches, not the effect, carry the gain')
    if unresolved:
        checks += f'; not significant: {unresolved[0]}'
    unit = getattr(data, 'position_unit', '')
    values = ', '.join(f'{act.name_in_unit(k, unit)} = {v:.4g}' for k, v in fit.values.items()
                       if k in eff.parameters) or 'modified PI (saturated plays)'
    return {'effect': name, 'validation_nrmse': v1, 'train_nrmse': fit.train['nrmse'],
            'improvement': gain, 'significant': significant,
            # the only check it failed: a rival to whatever is named instead
            'unresolved': unresolved if evident and carried and spread else None,
            'explanation': (f'held-out NRMSE {100 * v0:.2f} % -> {100 * v1:.2f} % '
                            f'({100 * gain:+.0f} % better), training NRMSE '
                            f'{100 * base.train["nrmse"]:.2f} % -> '
                            f'{100 * fit.train["nrmse"]:.2f} %, '
                            f'BIC change {bic_change:+.1f}{checks}; '
                            f'fitted {values}. Signature: {eff.signature}.'),
            'fit': fit, 'bic_change': float(bic_change), 'base_refit': base_refit}


def unresolved_by(eff: Effect, values: dict, data: Any,
                  base: Optional[ModelFit] = None) -> Optional[tuple]:
    """
    Return (why `data` cannot resolve the fitted effect, what would tell it apart), or None.

    Check 4: the effect's own resolution at the fitted `values` (`Effect.unresolved`: a
    delay or lag shorter than the sample period allows), a held-out window that only
    extrapolates from the `base` fit (`beyond_training`), and for an effect on the heating
    law (`Effect.heating_law`) training records that heat at one duty level
    (`levels.duty_levels`, on the fit's training window), where any heating law fits.
    """
    reason = eff.unresolved(values, data)
    if reason:
        return reason, 'at this sample rate the two are not told apart; record faster'
    beyond = None if base is None else beyond_training(data, base)
    if beyond is not None:
        share, error = beyond
        of_error = '' if error is None else f" ({100 * error:.0f} % of the base's error over it)"
        return (f'{100 * share:.0f} % of the held-out window{of_error} lies on branches of the '
                'loop beyond the positions the training window reached on them, and the base '
                "fits the training window to the noise: the gain is an extrapolation's",
                'hold out a record that the training records cover (two or more records, or '
                '--validate-on)')
    if not eff.heating_law or getattr(data, 'kind', None) != DynamicData.kind:
        return None
    levels = duty_levels(data, data.default_split())
    if levels is None or not levels.one_level:
        return None
    return (f'the training records heat at one duty level ({100 * levels.share:.0f} % of the '
            f'heated time at duty {levels.level:.3g}), where a heating law is not identified',
            'records at one duty level do not tell the two apart; record other duty levels')


def beyond_training(data: Any, base: ModelFit) -> Optional[Tuple[float, Optional[float]]]:
    """
    Return (held-out share, base error share) beyond the trained branches, where they rule.

    Over `MOSTLY_EXTRAPOLATED` of one record's held-out window, or of the base's squared
    error over it, lies beyond the positions its training window reached on each branch of
    the loop (`branches.extrapolated_share`, `extrapolated_error_share`) while the base fits
    the training window to within `NEAR_NOISE` of the noise floor (`noise_floor`): nothing
    in training shows an effect, and a held-out gain, won mostly where the base
    extrapolates, says which extrapolation fits. None otherwise; the error share is None
    when the base has no prediction or predicts the held-out window exactly.
    """
    share = extrapolated_share(data)
    if share is None:
        return None
    prediction = getattr(base, 'prediction', None)
    error = None if prediction is None else extrapolated_error_share(data, prediction)
    if max(share, error or 0.0) <= MOSTLY_EXTRAPOLATED:
        return None
    floor = noise_floor(data)
    return (share, error) if floor and base.train['nrmse'] <= NEAR_NOISE * floor else None


def prefer_warm(data: DynamicData, warm: Any, scratch: Any) -> bool:
    """
    Return True when a candidate's warm fit, not its fit from scratch, is to be judged.

    warm, scratch: fits with a `train['rmse']` (ModelFit or `identification.DynamicFit`).
    As `identification.fit_dynamic` chooses among its coarse grids: the fit from scratch
    (on the first coarse grid, as `fit --add` fits) stands where its training RMSE is within
    `NEAR_NOISE` times the noise's (`record_noise_rms`); otherwise the one of the two that
    trains better. At the noise, the warm one, on the base's grid, can train better by
    fitting noise with that grid's extra elements; its training lead does not say it holds
    out better.
    """
    if scratch.train['rmse'] <= NEAR_NOISE * record_noise_rms(data):
        return False
    return bool(warm.train['rmse'] <= scratch.train['rmse'])


def warm_trial_stands(data: DynamicData, warm: Any, scratch: Any) -> bool:
    """
    Return True when an own-grid candidate's best warm trial, not its best from scratch, stands.

    The trials are starts of one fit, so the lower training RMSE wins, as in any multi-start,
    where it is clearly lower: by `NEAR_TIE` (10 %), the bar `_rank_retarders_by_training`
    also holds two fits of one window to. Otherwise `prefer_warm`: where the two train alike,
    the trial from scratch at the noise stands, the model `fit --add` gives. The second pass
    judges its refits by `prefer_warm` alone: there the warm refit has already been judged
    (in the first pass) and the refit from scratch is the second opinion it asks for.
    """
    if warm.train['rmse'] < (1.0 - NEAR_TIE) * scratch.train['rmse']:
        return True
    return prefer_warm(data, warm, scratch)


def _regridded_base(data: DynamicData, base: ModelFit, fit: ModelFit,
                    eff: Effect) -> Optional[ModelFit]:
    """
    Return the base model refitted from where the candidate's refit ended.

    The counterfactual of the candidate's gain: the base's own parameters (time constant,
    weights) refitted on the candidate's hysteresis grid, warm from its values, with the
    effect off. When that does as well, the gain came from the new grid or a re-tuned
    base, not from the effect. None when it does not apply (static data, no parameters).
    """
    if not eff.parameters or fit.split is None or fit.split.start is None:
        return None
    names = {f.name for f in fields(act.ActuatorParams)}
    neutral = {k: getattr(base.params, k) for k in eff.parameters if k in names}
    start = {k: v for k, v in fit.values.items() if k not in eff.parameters}
    off = ModelFit(list(base.effects), base.kind, start, None, None, None, None, 0, None,
                   fit.params.with_changes(**neutral), grid=fit.grid)
    return fit_model(data, list(base.effects), kind=base.kind, base_fit=off)


def _flag_near_ties(ranked: list, gain: str = 'improvement') -> None:
    """
    Say in each explanation which significant candidates come within NEAR_TIE of the best.

    Their order stays the held-out one: by BIC the parameter count would decide (their
    training fits are alike), against effects with more parameters whatever held-out says.
    """
    sig = [c for c in ranked if c['significant']]
    if len(sig) < 2:
        return
    top = max(c[gain] for c in sig)   # the first may be a retarder ranked by training
    group = [c for c in sig if c[gain] >= (1.0 - NEAR_TIE) * top]
    if len(group) < 2:
        return
    names = ', '.join(c['effect'] for c in group)
    for c in group:
        if ' Near tie: ' in c['explanation']:
            continue   # ranked again after a later pass
        c['explanation'] += (f' Near tie: {names} improve the held-out error within '
                             f'{100 * NEAR_TIE:.0f} % of each other; the data barely '
                             'separate them.')
