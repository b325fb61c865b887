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
Workbench engine: fit a model with a set of effects, and score it on its records.

fit_model: the paper's base model (per-wire first-order thermal dynamics, modified PI,
linear shaft/sensor map, wires sharing parameters) plus the chosen catalog effects,
identified by `core.identification` (free-run error; train on the first 70 % of time or
on even curves, validate on the rest).

An effect with a grid of its own (`Effect.own_grid`) new to the base fit is fitted warm
from the base and from scratch; `warm_trial_stands` chooses between the two best trials.
The diagnosis of the missing effect built on these fits is in `judging` (the checks one
candidate must pass) and `diagnosis` (the passes over all candidates, their ranking, the
rounds).
"""
from dataclasses import dataclass, field
from functools import partial
from typing import Any, Callable, Optional

import numpy as np

from .effects import Effect, get_effect
from .records import (loop_prior, record_strokes, referred_to_rest, stroke_scale,
                      untared_offsets, zeros)
from ..core import actuator as act
from ..core.datakinds import DynamicData, Split, StaticData
from ..core.hysteresis import PlayHysteresis
from ..core.identification import fit_dynamic, SearchOptions
from ..core.scoring import NEAR_NOISE, record_noise_rms, scores
from ..core.static_fit import fit_static

# significant candidates whose held-out gains are this close (relative to the best) explain
# the data about equally well: the explanation says so
NEAR_TIE = 0.10
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


def noise_floor(data: Any) -> Optional[float]:
    """
    Return the NRMSE a perfect model would score on `data`: its measurement noise.

    σ / span, σ from `scoring.record_noise_rms` over each record's measured positions, span
    the range measured over the whole set (the NRMSE's scale); None for static curves,
    whose points are not a time series.
    """
    span = data.span()
    if not isinstance(data, DynamicData) or span <= 0:
        return None
    return record_noise_rms(data) / span


def held_out_cannot_judge(held_out: float, train: float) -> bool:
    """
    Return True when the held-out window is at the noise and the training window is not.

    held_out, train: a model's held-out and training NRMSE over the noise floor's
    (`noise_floor`): within `NEAR_NOISE` held out and beyond `TRAINING_MISFIT` in
    training, the held-out window does not show what the training window lacks.
    """
    return held_out <= NEAR_NOISE and train > TRAINING_MISFIT


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
