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
     effectively independent samples (n divided by the base residual's correlation
     length), so serially correlated residuals cannot buy extra parameters cheaply; the
     candidate nests the base model, so a missing effect must fit the training window
     better by more than its extra parameters' worth (a held-out gain without that is luck
     of the split, not physics), and
  3. the effect itself carries the gain (ablation): the candidate with its effect's
     parameters put back to the base model's values, keeping the re-fitted weights and
     time constant, must be worse on held-out data by at least `min_improvement` again;
     otherwise the gain came from re-tuning the base (a fragile held-out window), not
     from the effect, and
  4. the fitted effect is large enough for the data to resolve (`Effect.unresolved`; a
     delay must exceed one sample period).
Candidates are listed best first: significant ones by held-out improvement, then the
rest by held-out improvement; the first significant one is the missing effect. When
several significant candidates come within `NEAR_TIE` (10 %) of the best gain, the data
cannot really tell them apart: the one with the lowest BIC (the more parsimonious
explanation) is put first and every explanation in the group says so.
"""
from dataclasses import dataclass, field, fields
from functools import partial
import time

import numpy as np

from .effects import CATALOG, Effect, get_effect, is_builtin
from .parallel import available_cores, imap_on_cores
from .records import loop_prior, record_strokes, stroke_scale, zeros
from ..core import actuator as act
from ..core.hysteresis import PlayHysteresis
from ..core.identification import (DynamicData, fit_dynamic, fit_static, narrow_bands,
                                   record_span, scored_mask, scores)

MIN_IMPROVEMENT = 0.20
# BIC must fall by at least this much: "very strong" evidence on Kass & Raftery's (1995)
# scale; smaller falls come from training fits that hardly changed
BIC_MARGIN = 10.0
# significant candidates whose held-out gains are this close (relative to the best) explain
# the data about equally well: parsimony (BIC) decides between them
NEAR_TIE = 0.10


@dataclass
class StaticData:
    """Quasi-static curves: input, output, curve id per sample (curves start from reset)."""

    input: np.ndarray  # noqa: A003 (the pair input/output names the model's two signals)
    output: np.ndarray
    curve: np.ndarray

    def __len__(self):
        return len(self.input)


@dataclass
class ModelFit:
    """A fitted model: effects included, parameters, scores and predictions."""

    effects: list
    kind: str
    values: dict
    train: dict
    validation: dict
    prediction: object
    split: object
    n_parameters: int
    residual: np.ndarray                  # free-run residual on the training window
    params: object = None                 # ActuatorParams (dynamic) or PlayHysteresis (static)
    signals: dict = field(default_factory=dict)
    grid: object = None
    # rig description for the model file: layout, position_unit, records (name, sensor zero
    # [position unit], role), sensor_zero_rule
    rig: dict = field(default_factory=dict)
    burn_in: int = 0                      # first training sample (dynamic)

    def to_dict(self):
        """YAML-able form: effects, kind, fitted values, model parameters, scores."""
        model = (self.params.to_dict() if hasattr(self.params, 'hysteresis')
                 else {'hysteresis': self.params.to_dict()})
        d = {'effects': list(self.effects), 'kind': self.kind,
             'parameters': {k: float(v) for k, v in self.values.items()},
             'model': model, 'scores': {'train': self.train, 'validation': self.validation}}
        d.update(self.rig)
        return d

    def simulate(self, data):
        """Prediction of this fitted model on other data (same kind: dynamic or static)."""
        if isinstance(data, StaticData):
            h = self.params if isinstance(self.params, PlayHysteresis) else self.params.hysteresis
            u0 = float(np.min(data.input))
            return [(c, h.simulate(data.input[data.curve == c], h.initial_state(u0)))
                    for c in dict.fromkeys(data.curve.tolist())]
        return self.trajectory(data).position_rad

    def inputs(self, data):
        """
        (duty_a, duty_b, ambient) the thermal model sees on dynamic data.

        Plug-in input transforms applied with the fitted values, constant ambient if none was
        measured.
        """
        amb = (data.ambient if data.ambient is not None
               else np.full(len(data), self.params.ambient_c))
        return _hooked_inputs(self.effects, data.duty_a, data.duty_b, amb, self.values)

    def trajectory(self, data):
        """Free-run `core.actuator.Trajectory` of this model on dynamic data."""
        da, db, amb = self.inputs(data)
        t = act.simulate(self.params, da, db, data.dt, ambient_c=amb)
        if 'sensor_zero' in self.effects:
            t.position_rad = t.position_rad + zeros(data)
        return t


def _input_hooks(effects):
    """Effects (plug-ins) that transform the inputs."""
    return [get_effect(e) for e in effects
            if type(get_effect(e)).transform_inputs is not Effect.transform_inputs]


def _hooked_inputs(effects, duty_a, duty_b, ambient, values):
    """Input after every plug-in transform, duties clipped to [0, 1]."""
    for eff in _input_hooks(effects):
        duty_a, duty_b, ambient = eff.transform_inputs(duty_a, duty_b, ambient, values)
    return np.clip(duty_a, 0.0, 1.0), np.clip(duty_b, 0.0, 1.0), ambient


def load_fit(d, data=None):
    """Return a ModelFit from `to_dict` output; scores and predictions are recomputed on `data`."""
    model = d.get('model', {})
    if set(model) == {'hysteresis'}:
        params = PlayHysteresis.from_dict(model['hysteresis'])
    else:
        params = act.ActuatorParams.from_dict(model)
    sc = d.get('scores', {})
    fit = ModelFit(list(d.get('effects', [])), d.get('kind', 'modified'),
                   dict(d.get('parameters', {})), sc.get('train'), sc.get('validation'),
                   None, None, 0, np.zeros(0), params)
    if data is not None:
        if isinstance(data, StaticData):
            pred = fit.simulate(data)
            fit.validation = scores(data.output, np.concatenate([p for _, p in pred]))
        else:
            t = fit.trajectory(data)
            pred = t.position_rad
            keep = scored_mask(data)
            fit.validation = scores(data.position[keep], pred[keep], record_span(data))
            fit.signals = {'theta_a': t.theta_a_c, 'theta_b': t.theta_b_c, 'y_a': t.y_a,
                           'y_b': t.y_b, 'time': data.time}
        fit.prediction = pred
    return fit


def _kind(effects, kind):
    """Hysteresis kind implied by the effects (saturation -> modified)."""
    if 'saturation' in effects:
        return 'modified'
    return kind or 'modified'


def fit_model(data, effects=(), kind=None, progress=None, base_fit=None):
    """
    Fit the base model plus `effects` (catalog names) to dynamic or static data.

    kind: 'classical' or 'modified' PI base (default modified; 'saturation' forces
    modified). base_fit: a previous ModelFit whose grid and values warm-start this one.
    """
    effects = list(dict.fromkeys(effects))
    for e in effects:
        reason = not_applicable(get_effect(e), data)
        if reason:
            raise ValueError(f'effect {e} cannot be fitted on this data: {reason}')
    kind = _kind(effects, kind)
    if progress:
        progress(0, 1, 'fit ' + ('+'.join(effects) or 'base'))
    if isinstance(data, StaticData):
        extra = [e for e in effects if get_effect(e).needs_dynamic]
        if extra:
            raise ValueError(f'effects {extra} need dynamic (time-series) data')
        # the paper's least-squares tuning; the classical base is plain least squares
        res = fit_static(data.input, data.output, data.curve, kind=kind,
                         nonneg=(kind == 'modified'))
        val_ids = [c for c, _ in res.prediction if c % 2 == 1]
        pred_train = np.concatenate([p for c, p in res.prediction if c % 2 == 0])
        y_train = np.concatenate([data.output[data.curve == c] for c, _ in res.prediction
                                  if c % 2 == 0])
        fit = ModelFit(effects, kind, {}, res.train, res.validation, res.prediction, val_ids,
                       int(np.count_nonzero(res.model.w)) + 2, pred_train - y_train, res.model)
    else:
        fit = _fit_dynamic(data, effects, kind, base_fit)
    if progress:
        progress(1, 1, 'fit done')
    return fit


def not_applicable(eff, data):
    """Return why effect `eff` cannot be fitted on `data`, or None."""
    if eff.needs_two_wires and getattr(data, 'layout', None) == 'single':
        return 'needs two wires (this is a single wire against a bias spring)'
    return eff.applicable(data)


def split_masks(data, n_train, burn_in=0):
    """Return (train, validation) boolean masks of the scored samples of `data`."""
    n = len(data)
    train, val = np.zeros(n, bool), np.zeros(n, bool)
    train[burn_in:n_train], val[n_train:] = True, True
    keep = scored_mask(data)
    return train & keep, val & keep


# a held-out window whose measured range is below this fraction of the whole record set's
# range cannot tell models apart: its NRMSE is reported as uninformative
MIN_COVERAGE = 0.2


def rescore(data, pred, n_train, burn_in=0):
    """
    Return (train, validation) scores of `pred`, NRMSE over the whole record set's range.

    Each scores dict also has 'coverage': the range of the measured output in that part
    over the whole set's range, and 'informative': coverage >= MIN_COVERAGE.
    """
    train, val = split_masks(data, n_train, burn_in)
    return _part_scores(data, pred, train), _part_scores(data, pred, val)


def _part_scores(data, pred, mask):
    if not mask.any():
        return None
    span = record_span(data)
    y = data.position[mask]
    s = scores(y, pred[mask], span)
    s['coverage'] = float(np.ptp(y) / span) if span > 0 else 0.0
    s['informative'] = bool(s['coverage'] >= MIN_COVERAGE)
    return s


def record_scores(data, pred, n_train=None):
    """
    Return per-record scores of `pred` on joined `data`, NRMSE over the whole set's range.

    A list of {'data': name, 'role': 'train' | 'validation' | 'time split', 'scores':
    {'all': ...}}, one per record (whole record, rest gaps excluded).
    """
    out = []
    keep = scored_mask(data)
    for name, a, b in data.segments or (('DATA', 0, len(data)),):
        mask = np.zeros(len(data), bool)
        mask[a:b] = True
        if len(data.segments) < 2:
            role = 'time split'
        else:
            role = 'validation' if n_train is not None and a >= n_train else 'train'
        out.append({'data': name, 'role': role,
                    'scores': {'all': _part_scores(data, pred, mask & keep)}})
    return out


def _tared(data):
    """Return (`data` with each record's position relative to its start rest, the zeros)."""
    z = zeros(data)
    return DynamicData(data.time, data.duty_a, data.duty_b, data.position - z, data.ambient,
                       data.setpoint, data.position_unit, data.layout, data.segments,
                       data.scored, data.split), z


def _fit_dynamic(data, effects, kind, base_fit):
    tare = 'sensor_zero' in effects
    # the residual is the same either way: the tare cancels in model − measured
    fit_data = _tared(data)[0] if tare else data
    strokes = None
    if 'record_stroke' in effects:
        fit_data, strokes, base_fit = _stroked(fit_data, effects, kind, base_fit, tare)
    fit = _fit_dynamic_raw(fit_data, effects, kind, base_fit)
    if strokes is not None:   # back to each record's own stroke: m0 + ρ (p − m0)
        m0 = zeros(fit_data)
        fit.prediction = m0 + stroke_scale(fit_data, strokes) * (fit.prediction - m0)
    if tare:
        fit.prediction = fit.prediction + zeros(data)
    if strokes is not None:   # the residual of the records as measured (BIC in diagnose)
        train = split_masks(data, fit.split, fit.burn_in)[0]
        fit.residual = fit.prediction[train] - data.position[train]
    fit.train, fit.validation = rescore(data, fit.prediction, fit.split, fit.burn_in)
    fit.rig = rig_info(data, fit.split)
    if strokes is not None:
        fit.rig['record_strokes'] = strokes
    return fit


def _stroked(data, effects, kind, base_fit, tared):
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
        base_fit = _fit_dynamic_raw(data, pooled, kind, base_fit)
        pred = base_fit.prediction
    strokes = record_strokes(data, pred)
    m0 = zeros(data)
    y = m0 + (data.position - m0) / stroke_scale(data, strokes)
    return (DynamicData(data.time, data.duty_a, data.duty_b, y, data.ambient, data.setpoint,
                        data.position_unit, data.layout, data.segments, data.scored,
                        data.split), strokes, base_fit)


def rig_info(data, n_train=None):
    """
    Return the rig keys of a model file fitted on dynamic `data`.

    layout, position_unit and record_zeros: {record: its start rest [position unit]}
    (the sensor zero `sensor_zero` refers each record to), record_roles {record: train |
    validation | time split}.
    """
    z = zeros(data)
    segs = data.segments or (('DATA', 0, len(data)),)
    roles = {r['data']: r['role'] for r in record_scores(data, np.zeros(len(data)), n_train)}
    return {'layout': data.layout, 'position_unit': data.position_unit,
            'record_zeros': {name: float(z[a]) for name, a, _ in segs},
            'record_roles': roles}


def _fit_dynamic_raw(data, effects, kind, base_fit):
    free = {}
    start = dict(base_fit.values) if base_fit else {}
    alternatives = []
    params = (base_fit.params if base_fit is not None and hasattr(base_fit.params, 'hysteresis')
              else act.ActuatorParams())
    for e in effects:
        eff = get_effect(e)
        free.update(eff.bounds(params))
        for k, v in eff.start_values(data).items():
            start.setdefault(k, v)
        if base_fit is None or e not in base_fit.effects:
            alternatives += eff.alternative_starts(data)
    hook = partial(_hooked_inputs, effects) if _input_hooks(effects) else None
    same_grid = base_fit is not None and base_fit.kind == kind and base_fit.grid is not None
    # training data that never cools back leaves the descending branch to the datasheet loop
    loop_ratio = loop_prior(data)
    trials = [(alt, same_grid, {}) for alt in [{}] + alternatives]
    for eff in map(get_effect, effects):
        if same_grid and eff.name not in base_fit.effects and eff.own_grid:
            # also from scratch, on a grid of its own
            trials.append((eff.scratch_start(params), False, eff.scratch_bounds(params)))
    res = None
    for alt, warm, bounds in trials:
        trial = fit_dynamic(data, free=dict(free, **bounds), kind=kind,
                            grid=base_fit.grid if warm else None,
                            start=dict(start, **alt), input_hook=hook,
                            ref=base_fit.params.hysteresis if warm else None,
                            loop_ratio=loop_ratio)
        if res is None or trial.train['rmse'] < res.train['rmse']:
            res = trial
    train = split_masks(data, res.n_train, res.burn_in)[0]
    resid = res.prediction[train] - data.position[train]
    t = res.trajectory
    fit = ModelFit(effects, kind, res.free, res.train, res.validation, res.prediction,
                   res.n_train, res.n_parameters, resid, res.params,
                   {'theta_a': t.theta_a_c, 'theta_b': t.theta_b_c, 'y_a': t.y_a,
                    'y_b': t.y_b, 'time': data.time}, res.grid)
    fit.burn_in = res.burn_in
    return fit


def correlation_length(residual):
    """Lag (samples) where the residual's autocorrelation first drops below 1/e (>= 1)."""
    r = np.asarray(residual, float) - np.mean(residual)
    if len(r) < 4 or not np.any(r):
        return 1
    f = np.fft.rfft(r, 2 * len(r))
    acf = np.fft.irfft(f * np.conj(f))[: len(r)]
    acf /= acf[0]
    below = np.flatnonzero(acf < np.exp(-1))
    return int(below[0]) if below.size else len(r)


def bic(residual, n_parameters, n_eff):
    """BIC = n_eff ln(RSS/n) + k ln(n_eff) of a residual with k parameters."""
    r = np.asarray(residual, float)
    return n_eff * np.log(np.mean(r ** 2) + 1e-300) + n_parameters * np.log(max(n_eff, 2))


def _free_count(fit):
    return sum(len(get_effect(e).parameters) for e in fit.effects) + (
        1 if 'saturation' in fit.effects else 0)


@dataclass
class Diagnosis:
    """Result of `diagnose`."""

    baseline: ModelFit
    candidates: list
    missing_effect: object

    def to_json(self):
        """Return the `sma-model diagnose --json` document."""
        return {'baseline': {'effects': list(self.baseline.effects),
                             'validation_nrmse': self.baseline.validation['nrmse']},
                'candidates': [{k: v for k, v in c.items() if k not in ('fit', 'bic', 'seconds')}
                               for c in self.candidates],
                'missing_effect': self.missing_effect}


def diagnose(data, base=None, candidates=None, progress=None, min_improvement=MIN_IMPROVEMENT,
             kind=None, jobs=1):
    """
    Rank candidate effects by held-out error reduction; name the missing one (or None).

    base: a ModelFit (or None: fit the paper's base model, `kind` PI). candidates: effect
    names (default: every catalog effect not in the base). jobs: processes for the
    candidate refits (independent fits; 0 = every core). Plug-in effects are refitted in
    this process, since a worker process would not have them registered.
    """
    if base is None:
        base = fit_model(data, (), kind=kind)
    tasks = candidate_tasks(data, base, candidates, min_improvement)
    names = [t[2] for t in tasks]
    builtin = all(is_builtin(e) for e in base.effects)

    def poolable(name):   # a dynamic refit (worth a process) of an effect every process has
        return (builtin and is_builtin(name) and isinstance(data, DynamicData)
                and not_applicable(get_effect(name), data) is None)

    pooled, local = [], []
    for t in tasks:
        (pooled if poolable(t[2]) else local).append(t)
    # the slowest refits (a second one from scratch) first, so no core idles at the end
    pooled.sort(key=lambda t: not get_effect(t[2]).own_grid)
    workers = min(jobs or available_cores(), len(pooled))
    out = []

    def done(entry):
        out.append(entry)
        if progress:
            progress(len(out), len(names), entry['effect'])

    if progress:
        progress(0, len(names), 'candidates')
    for task in local + (pooled if workers <= 1 else []):
        done(judge_candidate(task))
    if workers > 1:
        for _, entry in imap_on_cores(judge_candidate, pooled, workers):
            done(entry)
    if progress:
        progress(len(names), len(names), 'done')
    return rank_candidates(base, out)


def candidate_tasks(data, base, candidates=None, min_improvement=MIN_IMPROVEMENT):
    """
    One `judge_candidate` task per candidate effect not already in `base`.

    A task is (data, base, name, n_eff, bic0, min_improvement): n_eff is the number of
    effectively independent training residual samples (n / correlation length) and bic0
    the base model's BIC on them, the reference every candidate is judged against.
    """
    names = [n for n in (candidates or CATALOG) if n not in base.effects]
    n_eff = max(len(base.residual) / correlation_length(base.residual), 2.0)
    bic0 = bic(base.residual, _free_count(base), n_eff)
    return [(data, base, name, n_eff, bic0, min_improvement) for name in names]


def rank_candidates(base, entries):
    """Return the `Diagnosis` of judged entries: significant first, by held-out gain."""
    out = sorted(entries, key=lambda c: (c['significant'], -np.inf if c['improvement'] is None
                                         else c['improvement']), reverse=True)
    _settle_near_ties(out)
    best = next((c['effect'] for c in out if c['significant']), None)
    return Diagnosis(base, out, best)


def diagnose_rounds(data, base, rounds, **kw):
    """
    Diagnose, add the missing effect, refit, diagnose again: up to `rounds` rounds.

    Stops when nothing is significant. The refit of a round is the named candidate's own
    refit (base grid, warm start, also from scratch for `own_grid` effects). Returns
    (the Diagnosis of every round, [{'added': name, 'validation_nrmse': x}, ...], the
    final ModelFit). kw: passed to `diagnose` (candidates, progress, jobs, ...).
    """
    diags, added = [], []
    for _ in range(max(int(rounds), 1)):
        diag = diagnose(data, base=base, **kw)
        diags.append(diag)
        best = next((c for c in diag.candidates if c['effect'] == diag.missing_effect), None)
        if best is None:
            break
        added.append({'added': best['effect'],
                      'validation_nrmse': best['fit'].validation['nrmse']})
        base = best['fit']
    return diags, added, base


def judge_candidate(task):
    """
    Refit with one candidate effect and judge it (see the module docstring).

    Returns the candidate's entry of `Diagnosis.candidates` (module level: runs in worker
    processes).
    """
    started = time.perf_counter()
    entry = _judge(*task)
    entry['seconds'] = time.perf_counter() - started
    return entry


def _judge(data, base, name, n_eff, bic0, min_improvement):
    """Return the candidate entry of `name` (without its time)."""
    eff = get_effect(name)
    reason = not_applicable(eff, data) if isinstance(data, DynamicData) else eff.applicable(data)
    if reason is None and isinstance(data, StaticData) and eff.needs_dynamic:
        reason = 'needs dynamic (time-series) data'
    if reason is None and name == 'saturation' and base.kind == 'modified':
        reason = 'the base model already saturates (modified PI)'
    if reason:
        return {'effect': name, 'validation_nrmse': None, 'improvement': None,
                'significant': False, 'explanation': f'not applicable: {reason}'}
    try:
        fit = fit_model(data, list(base.effects) + [name], kind=base.kind, base_fit=base)
    except ValueError as err:
        return {'effect': name, 'validation_nrmse': None, 'improvement': None,
                'significant': False, 'explanation': f'fit failed: {err}'}
    v0, v1 = base.validation['nrmse'], fit.validation['nrmse']
    gain = (v0 - v1) / v0 if v0 > 0 else 0.0
    bic1 = bic(fit.residual, _free_count(fit), n_eff)
    v_abl = _ablated_nrmse(data, base, fit, eff)
    # switching the effect off in the refit must cost at least the improvement asked of it
    carried = v_abl is None or v_abl <= 0 or (v_abl - v1) / v_abl >= min_improvement
    unresolved = eff.unresolved(fit.values, data)
    significant = bool(gain >= min_improvement and bic1 < bic0 - BIC_MARGIN and carried
                       and unresolved is None)
    checks = ('' if v_abl is None else
              f', {100 * v_abl:.2f} % with the effect switched off in the refit')
    if unresolved:
        checks += f'; not significant: {unresolved}'
    values = ', '.join(f'{k} = {v:.4g}' for k, v in fit.values.items()
                       if k in eff.parameters) or 'modified PI (saturated plays)'
    return {'effect': name, 'validation_nrmse': v1, 'improvement': gain,
            'significant': significant,
            'explanation': (f'held-out NRMSE {100 * v0:.2f} % -> {100 * v1:.2f} % '
                            f'({100 * gain:+.0f} % better), training NRMSE '
                            f'{100 * base.train["nrmse"]:.2f} % -> '
                            f'{100 * fit.train["nrmse"]:.2f} %, '
                            f'BIC change {bic1 - bic0:+.1f}{checks}; '
                            f'fitted {values}. Signature: {eff.signature}.'),
            'fit': fit, 'bic': float(bic1)}


def _ablated_nrmse(data, base, fit, eff):
    """
    Return the held-out NRMSE of `fit` with the effect's parameters back at the base values.

    The re-fitted weights and time constant are kept; None when that cannot be done (static
    data, no parameters, plug-in parameters without a neutral value).
    """
    if isinstance(data, StaticData) or not eff.parameters or fit.split is None:
        return None
    names = {f.name for f in fields(act.ActuatorParams)}
    changes, plug = {}, {}
    for k in eff.parameters:
        if k in names:
            changes[k] = getattr(base.params, k)
        elif k in eff.neutral:
            plug[k] = eff.neutral[k]
        else:
            return None
    # the refit's bands are narrowed to the states it visits in training; switched off, the
    # effect moves the states elsewhere, so start from the whole bands and narrow again
    h, g = fit.params.hysteresis, fit.grid
    if g is not None and g.n_operators == h.n_operators:
        h = PlayHysteresis(g.r, g.lo, g.hi, h.w, h.k1, h.y0)
    off = ModelFit(fit.effects, fit.kind, dict(fit.values, **plug), None, None, None, None, 0,
                   None, fit.params.with_changes(hysteresis=h, **changes))
    n = fit.split
    da, db, amb = off.inputs(data)
    off.params = narrow_bands(off.params, da[:n], db[:n], amb[:n], data.dt)
    pred = off.trajectory(data).position_rad
    return rescore(data, pred, fit.split)[1]['nrmse']


def _settle_near_ties(ranked):
    """Among significant candidates within NEAR_TIE of the best gain, lowest BIC first."""
    sig = [c for c in ranked if c['significant']]
    if len(sig) < 2:
        return
    group = [c for c in sig if c['improvement'] >= (1.0 - NEAR_TIE) * sig[0]['improvement']]
    if len(group) < 2:
        return
    group.sort(key=lambda c: c['bic'])
    names = ', '.join(c['effect'] for c in group)
    for c in group:
        c['explanation'] += (f' Near tie: {names} improve the held-out error within '
                             f'{100 * NEAR_TIE:.0f} % of each other; ranked by BIC (parsimony).')
    ranked[:len(group)] = group
