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
Where the model fails: error by regime and residual correlation tests.

The residual is e = measured − model, in the unit of the measured output.

Regimes (dynamic record), each a partition of the samples:

* ``thermal``   heating wire a / heating wire b / cooling / steady, from the sign of the
  model wire temperatures' rates dθ/dt (a wire heats when its rate exceeds
  `STEADY_RATE_K_PER_S`); without model temperatures a first-order thermal proxy of the
  duties (T = 2 s) stands in;
* ``direction`` rising / falling / holding measured output (rate of the smoothed output
  against `HOLD_RATE_FRACTION` of the measured range per second);
* ``loops``     major / minor: each monotone excursion between reversals of the smoothed
  output is major if it spans at least `MAJOR_LOOP_FRACTION` of the measured range;
* ``travel``    low end / middle / high end: measured output within the outer
  `END_FRACTION` of the measured range on either side;
* ``input_rate`` slow / fast input: total variation per second of the setpoint (or of
  duty_a − duty_b without a setpoint) over a 2 s window, split at its median;
* ``time``      quartiles Q1..Q4 of the record.

Static curves use ``thermal`` (input rising = heating), ``direction``, ``loops`` (a curve is
major if its input spans >= 90 % of the full input range), ``travel`` and ``curves``.

Only measured samples are compared (`DynamicData.scored`): the rests between joined records
and a bag's gaps in its joint states are cut out. The records then follow each other on
one time axis, while a gap inside a record keeps its length on the plotted axis
(`Comparison.axis`; `Comparison.kept` marks the compared samples of the record).

Residual tests: the sample autocorrelation of e at lags 1..L and its cross-correlation
with each signal u at lags −L..L, r(k) = Σ ẽ(t) ũ(t − k) / N on standardised signals
(dynamic: duties, model temperatures, ambient, position, end proximity |y − mid| / half
range, position rate, time; static: input, output, end proximity)
(k > 0: u leads the residual). Under a white residual independent of u, |r| stays within
the 99 % band ±2.576/√N; lags beyond it are flagged. (The band assumes a white
residual: a strongly coloured residual exceeds it on many signals, so the strength
max|r| / band ranks them.)
"""
from dataclasses import dataclass, field
from typing import Any, Dict, Optional

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import lfilter

from .engine import part_scores
from .records import partly_measured
from .remaining import percent as _pct
from ..core.datakinds import DynamicData, Split, StaticData

Z99 = 2.576
STEADY_RATE_K_PER_S = 0.1
HOLD_RATE_FRACTION = 0.02      # of the measured range per second
MAJOR_LOOP_FRACTION = 0.6
END_FRACTION = 0.1
PROXY_TAU_S = 2.0
SMOOTH_S = 0.25
RATE_WINDOW_S = 2.0
MAX_LAG_S = 2.0
CONCENTRATION_RATIO = 1.5      # regime RMSE / overall RMSE flagged as "error concentrates"
MIN_SHARE = 0.02               # ... if the regime holds at least this fraction of samples


@dataclass
class Comparison:
    """Result of `compare`; `to_json()` gives the plain-data form printed by the CLI."""

    kind: str                       # 'dynamic' | 'static' (the data's `kind`)
    measured: np.ndarray
    predicted: np.ndarray
    scores: dict                    # 'all', 'train', 'validation' -> scores() dict or None
    regimes: dict                   # group -> list of row dicts (see `breakdown`)
    concentrated: list              # rows where the error concentrates, worst first
    correlations: dict              # see `residual_tests`
    axis: np.ndarray = None         # time [s] (dynamic) or sample index (static)
    train_mask: np.ndarray = None
    signals: dict = field(default_factory=dict)   # for plots: dynamic theta_a, theta_b,
    #   proxy, duty_diff; static input, curve
    unit: str = ''                  # unit of the measured output ('' if not known)
    figures: tuple = ()             # (file, caption) of the data kind's own report figures
    axis_label: str = ''            # label of the sample axis
    kept: np.ndarray = None         # the record's samples compared (None: all of them)

    @property
    def residual(self) -> np.ndarray:
        """E = measured − model."""
        return self.measured - self.predicted

    def to_json(self) -> dict:
        """Plain-data (JSON-able) summary without the sample arrays."""
        corr = self.correlations
        return {'kind': self.kind, 'scores': self.scores, 'regimes': self.regimes,
                'concentrated': [f"{r['group']}: {r['label']}" for r in self.concentrated],
                'residual_tests': {
                    'band': corr['band'], 'max_lag': corr['max_lag'],
                    'lag_unit': corr['lag_unit'],
                    'autocorrelation': _summary_json(corr['autocorrelation']),
                    'cross_correlation': {k: _summary_json(v)
                                          for k, v in corr['cross'].items()},
                    'untested': corr['untested'],
                    'flagged': corr['flagged']}}


def _summary_json(test: dict) -> dict:
    """Return a lag test without its arrays (lags, r)."""
    return {k: v for k, v in test.items() if k not in ('lags', 'r')}


def compare(data: Any, prediction: np.ndarray, signals: Optional[dict] = None,
            split: Optional[Split] = None) -> Comparison:
    """
    Compare measured `data` with a model `prediction`: scores, regimes, residual tests.

    data: DynamicData or StaticData. prediction: the model output at every sample (a
    `ModelFit.prediction`). signals: model signals (dict with 'theta_a', 'theta_b' [°C]).
    split: where validation starts (default: the data's `default_split`, 70 % of the
    record or the odd curves). Unmeasured samples (`DynamicData.scored`) are left out of
    everything (`measured_view`); the axis keeps a gap inside a record (`plot_axis`).
    """
    y_hat = np.asarray(prediction, float)
    if y_hat.shape != np.shape(data.output):
        raise ValueError(f'prediction has {y_hat.size} samples, the record {len(data.output)}')
    kept = partly_measured(getattr(data, 'scored', None))
    if kept is not None:
        gapped = plot_axis(data, kept)
        split = data.scored_split(split)
        data, y_hat, signals = measured_view(data, kept, y_hat, signals or {})
    y = np.asarray(data.output, float)
    train = ~data.held_out(split)
    axis, masks, tests, plane = _VIEWS[data.kind](data, y, y_hat, signals or {}, split)
    if kept is not None:
        axis = gapped
    span = float(np.ptp(y))
    # every part is normalised by the range over the whole record set (a quiet window
    # would otherwise look like a huge relative error), and says how much of it it covers
    sc = {'all': part_scores(data, y_hat, np.ones(y.size, bool)),
          'train': part_scores(data, y_hat, train),
          'validation': part_scores(data, y_hat, ~train)}
    rows = breakdown(y - y_hat, masks, span)
    return Comparison(data.kind, y, y_hat, _finite(sc), rows,
                      concentrations(rows, sc['all']['rmse']), tests, axis, train, plane,
                      unit=data.output_unit, figures=data.figures,
                      axis_label=data.axis_label, kept=kept)


def measured_view(data: DynamicData, kept: np.ndarray, prediction: np.ndarray,
                  signals: dict) -> tuple:
    """
    Return (data, prediction, signals) cut to the `kept` samples, on one uniform time axis.

    The regimes, rates and residual tests then see the records one after the other, with
    neither the rests between them nor a bag's gaps.
    """
    def cut(x: Optional[np.ndarray]) -> Optional[np.ndarray]:
        return None if x is None else np.asarray(x)[kept]
    n = int(kept.sum())
    view = DynamicData(data.time[0] + np.arange(n) * data.dt, cut(data.duty_a),
                       cut(data.duty_b), cut(data.position), cut(data.ambient),
                       cut(data.setpoint), data.position_unit, data.layout)
    sig = {k: (view.time if k == 'time' else cut(v)) for k, v in signals.items()}
    return view, cut(prediction), sig


def plot_axis(data: DynamicData, kept: np.ndarray) -> np.ndarray:
    """
    Return the time [s] from the start at which each kept sample is plotted.

    t_k = dt × (number of samples before k that are kept or lie inside a record): the rests
    between joined records take no time on the plot, a gap inside a record (a bag's lost
    joint states) takes its own, so the time of every record's events reads as recorded.
    """
    inside = np.zeros(len(kept), bool)
    for _, start, stop in data.segments or (('', 0, len(kept)),):
        inside[start:stop] = True
    counted = np.cumsum(kept | inside) - 1
    return counted[kept] * data.dt


def _dynamic_view(data: DynamicData, y: np.ndarray, y_hat: np.ndarray, signals: dict,
                  split: Optional[Split]) -> tuple:
    """Return (time axis [s], regimes, residual tests, plot signals) of a dynamic record."""
    temps = thermal_signals(data, signals)
    masks = dynamic_regimes(data, temps)
    tests = residual_tests(y - y_hat, correlation_signals(data, temps), data.dt, 's')
    plane = dict(temps, duty_diff=data.duty_a - data.duty_b)
    return data.time - data.time[0], masks, tests, plane


def _static_view(data: StaticData, y: np.ndarray, y_hat: np.ndarray, signals: dict,
                 split: Optional[Split]) -> tuple:
    """Return (sample axis, regimes, residual tests, plot signals) of static curves."""
    masks = static_regimes(data, list((split or data.default_split()).curves))
    signals = {'input': np.asarray(data.input, float), 'output': y,
               'end proximity': end_proximity(y)}
    tests = residual_tests(y - y_hat, signals, 1.0, 'samples')
    plane = {'input': signals['input'], 'curve': np.asarray(data.curve)}
    return np.arange(len(y), dtype=float), masks, tests, plane


# the kind-specific part of a comparison, by `data.kind`
_VIEWS = {DynamicData.kind: _dynamic_view, StaticData.kind: _static_view}


# ------------------------------------------------------------------------------ regimes
def thermal_signals(data: DynamicData, signals: dict) -> dict:
    """Model wire temperatures [°C] {'theta_a', 'theta_b'}, or a duty proxy if absent."""
    if signals.get('theta_a') is not None and signals.get('theta_b') is not None:
        return {'theta_a': np.asarray(signals['theta_a'], float),
                'theta_b': np.asarray(signals['theta_b'], float), 'proxy': False}
    a = np.exp(-data.dt / PROXY_TAU_S)
    proxy = {k: lfilter([1 - a], [1, -a], getattr(data, 'duty_' + k[-1]), zi=[0.0])[0]
             for k in ('theta_a', 'theta_b')}
    # a proxy in "duty" units: scale to a nominal 100 K rise so thresholds keep their meaning
    return {k: 100.0 * v for k, v in proxy.items()} | {'proxy': True}


def smooth(x: np.ndarray, n: float) -> np.ndarray:
    """Centred moving average over n samples (edges: nearest value)."""
    return uniform_filter1d(np.asarray(x, float), max(1, int(n)), mode='nearest')


def direction_masks(smoothed: np.ndarray, span: float, dt: float) -> dict:
    """
    Return {rising, falling, holding: boolean mask} of a smoothed output.

    Holding: its rate within ±`HOLD_RATE_FRACTION` · span per second (span: the measured
    range, in the output's unit); rising and falling beyond it.
    """
    rate = np.gradient(smoothed, dt)
    hold = HOLD_RATE_FRACTION * span
    return {'rising': rate > hold, 'falling': rate < -hold, 'holding': np.abs(rate) <= hold}


def dynamic_regimes(data: DynamicData, temps: dict) -> dict:
    """Group -> {label: boolean mask} for a dynamic record (see module doc)."""
    y, dt = data.position, data.dt
    span = max(float(np.ptp(y)), 1e-12)
    ys = smooth(y, round(SMOOTH_S / dt))
    ra = np.gradient(temps['theta_a'], dt)
    rb = np.gradient(temps['theta_b'], dt)
    heat_a = (ra > STEADY_RATE_K_PER_S) & (ra >= rb)
    heat_b = (rb > STEADY_RATE_K_PER_S) & ~heat_a
    cooling = ~heat_a & ~heat_b & ((ra < -STEADY_RATE_K_PER_S) | (rb < -STEADY_RATE_K_PER_S))
    speed = input_rate(data)
    fast = speed > np.median(speed)
    n = len(y)
    quart = np.minimum((4 * np.arange(n)) // n, 3)
    return {
        'thermal': {'heating wire a': heat_a, 'heating wire b': heat_b, 'cooling': cooling,
                    'steady': ~(heat_a | heat_b | cooling)},
        'direction': direction_masks(ys, span, dt),
        'loops': loop_masks(ys, span),
        'travel': travel_masks(y),
        'input_rate': {'slow': ~fast, 'fast': fast},
        'time': {f'Q{q + 1}': quart == q for q in range(4)},
    }


def input_rate(data: DynamicData) -> np.ndarray:
    """Total variation per second of the setpoint (or duty_a − duty_b) over a 2 s window."""
    sp = data.setpoint
    u = sp if sp is not None and np.ptp(sp) > 0 else data.duty_a - data.duty_b
    du = np.abs(np.diff(u, prepend=u[0])) / data.dt
    return smooth(du, round(RATE_WINDOW_S / data.dt))


def reversals(y: np.ndarray, threshold: float) -> list:
    """Indicate of the turning points of y: extremes after which y moves back by > threshold."""
    turns, direction, lo, hi, extreme = [], 0, 0, 0, 0
    for k in range(1, len(y)):
        if direction == 0:   # until the first move larger than the threshold
            lo = k if y[k] < y[lo] else lo
            hi = k if y[k] > y[hi] else hi
            if y[hi] - y[lo] > threshold:
                direction = 1 if hi > lo else -1
                start, extreme = (lo, hi) if direction > 0 else (hi, lo)
                if start > 0:
                    turns.append(start)
        elif (y[k] - y[extreme]) * direction > 0:
            extreme = k
        elif (y[extreme] - y[k]) * direction > threshold:
            turns.append(extreme)
            direction, extreme = -direction, k
    return turns


def loop_masks(ys: np.ndarray, span: float) -> dict:
    """{'major', 'minor'}: excursions between reversals spanning >= MAJOR_LOOP_FRACTION of span."""
    turns = [0] + reversals(ys, 0.05 * span) + [len(ys) - 1]
    major = np.zeros(len(ys), bool)
    for a, b in zip(turns[:-1], turns[1:]):
        if abs(ys[b] - ys[a]) >= MAJOR_LOOP_FRACTION * span:
            major[a:b + 1] = True
    return {'major': major, 'minor': ~major}


def travel_masks(y: np.ndarray) -> dict:
    """{'low end', 'middle', 'high end'}: outer END_FRACTION of the measured range."""
    lo, hi = float(np.min(y)), float(np.max(y))
    edge = END_FRACTION * (hi - lo)
    low, high = y <= lo + edge, y >= hi - edge
    return {'low end': low, 'middle': ~low & ~high, 'high end': high & ~low}


def static_regimes(data: StaticData, val_ids: list) -> dict:
    """Group -> {label: mask} for static curves (see module doc)."""
    u = np.asarray(data.input, float)
    y = np.asarray(data.output, float)
    curve = np.asarray(data.curve)
    du, dy = np.zeros_like(u), np.zeros_like(y)
    major = np.zeros(len(u), bool)
    u_span = max(float(np.ptp(u)), 1e-12)
    curves = {}
    for cid in np.unique(curve):
        m = curve == cid
        du[m] = np.gradient(u[m])
        dy[m] = np.gradient(y[m])
        major[m] = np.ptp(u[m]) >= 0.9 * u_span
        curves[f'curve {cid} ({"validation" if cid in val_ids else "train"})'] = m
    flat_y = np.abs(dy) <= 1e-3 * max(float(np.ptp(y)), 1e-12)
    return {
        'thermal': {'heating (input rising)': du > 0, 'cooling (input falling)': du < 0,
                    'hold': du == 0},
        'direction': {'rising': (dy > 0) & ~flat_y, 'falling': (dy < 0) & ~flat_y,
                      'flat': flat_y},
        'loops': {'major': major, 'minor': ~major},
        'travel': travel_masks(y),
        'curves': curves,
    }


def breakdown(residual: np.ndarray, masks: dict, span: float) -> dict:
    """
    Group -> rows {group, label, samples, fraction, rmse, nrmse, bias, error_share}.

    nrmse = regime RMSE / measured range; bias = mean residual; error_share = the regime's
    share of the total squared error. Empty regimes have None figures.
    """
    e = np.asarray(residual, float)
    total = float(np.sum(e ** 2)) or 1.0
    out = {}
    for group, labels in masks.items():
        rows = []
        for label, m in labels.items():
            k = int(np.count_nonzero(m))
            row = {'group': group, 'label': label, 'samples': k, 'fraction': k / len(e)}
            if k:
                rmse = float(np.sqrt(np.mean(e[m] ** 2)))
                row.update(rmse=rmse, nrmse=rmse / span if span > 0 else None,
                           bias=float(np.mean(e[m])),
                           error_share=float(np.sum(e[m] ** 2)) / total)
            else:
                row.update(rmse=None, nrmse=None, bias=None, error_share=None)
            rows.append(row)
        out[group] = rows
    return out


def concentrations(rows_by_group: dict, rmse_all: float) -> list:
    """Rows whose RMSE is >= CONCENTRATION_RATIO x overall and hold >= MIN_SHARE of samples."""
    hits = [r for rows in rows_by_group.values() for r in rows
            if r['rmse'] is not None and r['fraction'] >= MIN_SHARE and rmse_all > 0
            and r['rmse'] >= CONCENTRATION_RATIO * rmse_all]
    return sorted(hits, key=lambda r: -r['rmse'])


# ------------------------------------------------------------------------------ residual tests
def correlation_signals(data: DynamicData, temps: dict) -> dict:
    """Signals tested against the residual: inputs, temperatures, ambient, position, rate, time."""
    out = {'duty_a': data.duty_a, 'duty_b': data.duty_b}
    label = ' (proxy)' if temps.get('proxy') else ''
    out[f'theta_a{label}'] = temps['theta_a']
    out[f'theta_b{label}'] = temps['theta_b']
    if data.ambient is not None:
        out['ambient'] = data.ambient
    out['position'] = data.position
    out['end proximity'] = end_proximity(data.position)
    out['position rate'] = np.gradient(smooth(data.position, round(SMOOTH_S / data.dt)), data.dt)
    out['time'] = data.time
    return out


def end_proximity(y: np.ndarray) -> np.ndarray:
    """|y − mid-travel| / half the measured range: 0 in the middle, 1 at either end."""
    y = np.asarray(y, float)
    half = 0.5 * float(np.ptp(y))
    mid = float(np.min(y)) + half
    return np.abs(y - mid) / half if half > 0 else np.zeros_like(y)


def standardise(x: np.ndarray) -> Optional[np.ndarray]:
    """(x − mean) / std, or None if x is constant."""
    x = np.asarray(x, float)
    sd = float(np.std(x))
    return None if sd == 0 or not np.isfinite(sd) else (x - x.mean()) / sd


def cross_correlation(e: np.ndarray, u: np.ndarray, max_lag: int) -> np.ndarray:
    """r(k) = Σ_t e(t) u(t − k) / N for k = −max_lag..max_lag (inputs standardised)."""
    n = len(e)
    nfft = 1 << int(np.ceil(np.log2(2 * n)))
    c = np.fft.irfft(np.fft.rfft(e, nfft) * np.conj(np.fft.rfft(u, nfft)), nfft) / n
    return np.concatenate([c[nfft - max_lag:], c[:max_lag + 1]])


def _lag_test(lags: np.ndarray, r: np.ndarray, band: float, step: float, unit: str) -> dict:
    """Return the figures of one correlation against its ±band (see `residual_tests`)."""
    over = np.abs(r) > band
    k = int(np.argmax(np.abs(r)))
    return {'lags': lags, 'r': r, 'max_abs': float(abs(r[k])), 'at_lag': float(lags[k] * step),
            'strength': float(abs(r[k]) / band), 'exceeds': bool(over.any()),
            'fraction_over': float(over.mean()), 'lags_over': _runs(lags[over] * step),
            'unit': unit}


def _runs(values: np.ndarray, limit: int = 10) -> list:
    """Contiguous runs of flagged lags as [from, to] pairs (at most `limit`)."""
    if values.size == 0:
        return []
    runs, start, prev = [], values[0], values[0]
    step = np.min(np.diff(values)) if values.size > 1 else 1.0
    for v in values[1:]:
        if v - prev > 1.5 * step:
            runs.append([float(start), float(prev)])
            start = v
        prev = v
    runs.append([float(start), float(prev)])
    return runs[:limit]


def residual_tests(residual: np.ndarray, signals: dict, dt: float, unit: str,
                   max_lag: Optional[int] = None) -> dict:
    """
    Autocorrelation of the residual and its cross-correlation with each signal.

    dt: lag step in `unit` ('s' for time, 'samples' for static curves); max_lag in samples
    (default: MAX_LAG_S of lags, at least 10, at most N/4). Returns {band, max_lag, lag_unit,
    autocorrelation: test, cross: {name: test}, untested: [constant signals], flagged:
    [names exceeding the band, strongest first]}, a test holding lags, r, max_abs, at_lag,
    strength (max_abs / band), exceeds, fraction_over and lags_over (runs of flagged lags).
    """
    n = len(residual)
    if max_lag is None:
        max_lag = int(round(MAX_LAG_S / dt)) if unit == 's' else 20
        max_lag = max(10, min(max_lag, n // 4))
    band = Z99 / np.sqrt(n)
    e = standardise(residual)
    out = {'band': float(band), 'max_lag': max_lag * dt, 'lag_unit': unit, 'cross': {},
           'untested': [], 'flagged': []}
    if e is None:   # a perfect (or constant-offset) model: nothing to correlate
        zero = np.zeros(max_lag)
        out['autocorrelation'] = _lag_test(np.arange(1, max_lag + 1), zero, band, dt, unit)
        out['untested'] = list(signals)
        return out
    lags = np.arange(-max_lag, max_lag + 1)
    auto = cross_correlation(e, e, max_lag)[max_lag + 1:]
    out['autocorrelation'] = _lag_test(lags[max_lag + 1:], auto, band, dt, unit)
    for name, u in signals.items():
        us = standardise(u)
        if us is None:
            out['untested'].append(name)
            continue
        out['cross'][name] = _lag_test(lags, cross_correlation(e, us, max_lag), band, dt, unit)
    flagged = [(k, v['strength']) for k, v in out['cross'].items() if v['exceeds']]
    out['flagged'] = [k for k, _ in sorted(flagged, key=lambda kv: -kv[1])]
    return out


def _finite(obj: Any) -> Any:
    """Replace non-finite floats by None (JSON has no NaN/inf), recursively."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def summary_lines(comparison: Comparison, top: int = 5, noise: Optional[str] = None) -> list:
    """
    Short text summary: scores, where the error concentrates, strongest residual links.

    noise: a line set under the scores (`remaining.noise_line`: the noise's score).
    """
    sc = comparison.scores
    lines = [score_line(part, sc[part], comparison.unit)
             for part in ('train', 'validation', 'all') if sc.get(part)]
    lines += [noise] if noise else []
    if comparison.concentrated:
        lines.append('error concentrates in: ' + ', '.join(
            f"{r['group']} {r['label']} (RMSE x{r['rmse'] / sc['all']['rmse']:.1f})"
            for r in comparison.concentrated[:top]))
    else:
        lines.append('error is spread evenly over the regimes')
    corr = comparison.correlations
    auto = corr['autocorrelation']
    lines.append(f"residual autocorrelation: max |r| {auto['max_abs']:.2f} "
                 f"(99 % band ±{corr['band']:.3f}){' - not white' if auto['exceeds'] else ''}")
    if corr['flagged']:
        lines.append('residual correlates with: ' + ', '.join(
            f"{k} (|r| {corr['cross'][k]['max_abs']:.2f} at lag {corr['cross'][k]['at_lag']:g} "
            f"{corr['lag_unit']})" for k in corr['flagged'][:top]))
    return lines


def score_line(part: str, s: Optional[Dict[str, Any]], unit: str = '',
               width: int = 10, held_out: Optional[bool] = None) -> str:
    """
    Return 'validation: NRMSE 1.23 %  RMSE 0.1 mm ...' for a scores dict (or n/a).

    A held-out part (`held_out`, default: the 'validation' part) whose measured range
    covers less than `engine.MIN_COVERAGE` of the whole set's is reported as uninformative, not
    scored.
    """
    if not s:
        return f'{part:>{width}}: n/a'
    u = f' {unit}' if unit else ''
    if (part == 'validation' if held_out is None else held_out) \
            and s.get('informative') is False:
        return (f'{part:>{width}}: uninformative: the held-out part covers '
                f'{100 * s["coverage"]:.0f} % of the measured range (hold out another record; '
                f'RMSE {s["rmse"]:.4g}{u})')
    return (f'{part:>{width}}: NRMSE {_pct(s["nrmse"])}  RMSE {s["rmse"]:.4g}{u}  fit '
            f'{_num(s["fit_percent"])} %  max error {s["max_error"]:.4g}{u}')


def _num(x: Optional[float]) -> str:
    """Return a number with one decimal, 'n/a' for None."""
    return 'n/a' if x is None else f'{x:.1f}'
