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
HTML report with PNG figures (matplotlib Agg, no display needed).

Files written into the report directory (nothing else is touched):

* ``index.html``      scores, figures, error by regime, residual tests, diagnosis
* ``time.png``        measured vs model over time, train/validation split marked
                      (static data: ``curves.png``, input-output plane per curve)
* ``residual.png``    residual over time (static: over the sample index, per curve)
* ``hysteresis.png``  hysteresis plane: measured and model position vs model wire
                      temperature difference θa − θb (or duty_a − duty_b) – dynamic only
* ``regimes.png``     error (NRMSE) by regime, one panel per regime group
* ``correlation.png`` residual autocorrelation and cross-correlations with 99 % bands
"""
import html
import os
from pathlib import Path
from typing import Any, Optional, Union

from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
import numpy as np

from .compare import Comparison, CONCENTRATION_RATIO, MIN_SHARE
from .remaining import percent as _pct, remaining_lines, rounds_lines
from ..core.model_file import creation_problem

PathLike = Union[str, os.PathLike]

REPORT_FILES = ('index.html', 'time.png', 'curves.png', 'residual.png', 'hysteresis.png',
                'regimes.png', 'correlation.png')
DPI = 90
GAP_STEPS = 1.5     # a step of the plotted time axis over this many samples is a gap
MAX_CROSS_PANELS = 8


class ReportError(ValueError):
    """The report directory cannot be used; the message names it."""


def check_report_dir(directory: PathLike, force: bool = False) -> None:
    """
    Raise `ReportError` if `directory` cannot take a report.

    That is: it is a file, already holds report files (without force), or neither it nor
    its parent can take a new file (`core.model_file.creation_problem`).
    """
    directory = Path(directory)
    if directory.exists() and not directory.is_dir():
        raise ReportError(f'{directory}: exists and is not a directory')
    present = [f for f in REPORT_FILES if (directory / f).exists()]
    if present and not force:
        raise ReportError(f'{directory}: already holds a report ({", ".join(present)}); use '
                          '--force to overwrite it')
    if not directory.exists() and not directory.parent.is_dir():
        raise ReportError(f'{directory}: parent directory {directory.parent} does not exist')
    where = directory if directory.exists() else directory.parent
    problem = creation_problem(where)
    if problem:
        raise ReportError(f'{directory}: cannot write in {where} ({problem})')


def write_report(directory: PathLike, comparison: Comparison, title: str, *,
                 data_line: str = '', model: Optional[dict] = None,
                 diagnosis: Optional[dict] = None, alternative: Optional[tuple] = None,
                 force: bool = False) -> Path:
    """
    Write the report; returns the path of index.html.

    comparison: `compare.Comparison`. model: {'effects', 'kind', 'parameters'} shown in the
    summary. diagnosis: `diagnose(...).to_json()` dict, shown as a ranked table.
    alternative: (label, prediction over the record) drawn next to the model, e.g. the
    model with the missing effect added (at every sample of the record, as the
    comparison's data). force: overwrite an existing report.
    """
    check_report_dir(directory, force)
    directory = Path(directory)
    directory.mkdir(exist_ok=True)
    if alternative is not None and comparison.kept is not None:
        alternative = (alternative[0], np.asarray(alternative[1])[comparison.kept])
    # the data kind names its own figures (`DynamicData.figures`, `StaticData.figures`)
    figures = [(name, caption, _PLOTS[name](comparison, alternative))
               for name, caption in comparison.figures]
    figures.append(('regimes.png', 'Where the error concentrates (NRMSE by regime)',
                    plot_regimes(comparison)))
    figures.append(('correlation.png', 'Residual tests with 99 % bands',
                    plot_correlations(comparison)))
    for name, _, fig in figures:
        save(fig, directory / name)
    page = render_html(comparison, title, data_line, model, diagnosis, figures)
    index = directory / 'index.html'
    index.write_text(page, encoding='utf-8')
    return index


def write_diagnosis_report(directory: PathLike, data: Any, diagnosis: Any, title: str,
                           data_line: str, force: bool = False,
                           doc: Optional[dict] = None) -> Path:
    """
    Write the report of a `diagnosis.Diagnosis` on `data`; returns the path of index.html.

    The base model is compared with the data, and the model with the missing effect added
    (if one was named) is drawn beside it. doc: the diagnosis as shown (default
    `diagnosis.to_json()`; `sma-model diagnose` adds its rounds).
    """
    from .compare import compare
    base = diagnosis.baseline
    best = next((c for c in diagnosis.candidates if c['effect'] == diagnosis.missing_effect),
                None)
    alternative = (f'model + {best["effect"]}', best['fit'].prediction) if best else None
    result = compare(data, base.prediction, base.signals, split=base.split)
    model = {'effects': base.effects, 'kind': base.kind, 'parameters': base.shown_values()}
    return write_report(directory, result, title, data_line=data_line, model=model,
                        diagnosis=diagnosis.to_json() if doc is None else doc,
                        alternative=alternative, force=force)


def save(fig: Figure, path: PathLike) -> None:
    """Render a matplotlib Figure to PNG with the Agg canvas."""
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=DPI)


def save_rounds_plot(directory: PathLike, doc: dict) -> Path:
    """
    Write rounds.png: validation NRMSE [%] after each round of `diagnose --rounds`.

    doc: the diagnose JSON document with 'baseline' and 'rounds'; an effect removed after
    the rounds (`diagnosis.prune_effects`) is a last point; returns the path.
    """
    removed = [r for r in doc['rounds'] if r.get('removed')]
    labels = (['base'] + [f'+ {r["added"]}' for r in doc['rounds']]
              + [f'- {r["added"]}' for r in removed])
    values = ([doc['baseline']['validation_nrmse']]
              + [r['validation_nrmse'] for r in doc['rounds']]
              + [r['validation_nrmse_without'] for r in removed])
    fig, axes = _figure(w=max(4, 1.6 * len(labels)), h=3.5)
    ax = axes[0, 0]
    ax.plot(range(len(values)), 100 * np.asarray(values, float), 'o-', color='tab:red')
    ax.set_xticks(range(len(values)), labels, fontsize=8)
    ax.set(ylabel='validation NRMSE [%]', ylim=(0, None),
           title='held-out error, round by round')
    path = Path(directory) / 'rounds.png'
    save(fig, path)
    return path


def _figure(w: float = 10, h: float = 4, rows: int = 1, cols: int = 1, **kw: Any) -> tuple:
    """Return (Figure, 2-D array of axes) of w x h inches [in]."""
    fig = Figure(figsize=(w, h), layout='constrained')
    axes = fig.subplots(rows, cols, squeeze=False, **kw)
    return fig, axes


def _mark_split(ax: Any, comparison: Comparison) -> None:
    """Shade the validation part of the sample axis."""
    train = comparison.train_mask
    if train is None or train.all() or not train.any():
        return
    x = comparison.axis
    start = x[np.flatnonzero(~train)[0]]
    ax.axvspan(start, x[-1], color='0.92', zorder=0)
    ax.axvline(start, color='0.4', lw=1, ls='--')
    ax.text(start, 1.0, '  validation', transform=ax.get_xaxis_transform(), va='top',
            fontsize=8, color='0.3')
    ax.text(x[0], 1.0, 'train', transform=ax.get_xaxis_transform(), va='top', fontsize=8,
            color='0.3')


def _gaps(comparison: Comparison) -> np.ndarray:
    """Return the indices where the plotted axis jumps over a gap inside a record."""
    x = comparison.axis
    if comparison.kept is None or len(x) < 2:
        return np.zeros(0, int)
    steps = np.diff(x)
    return np.flatnonzero(steps > GAP_STEPS * np.median(steps)) + 1


def _broken(gaps: np.ndarray, *arrays: np.ndarray) -> tuple:
    """Return the arrays with a NaN before each index in `gaps`: the line breaks there."""
    return tuple(np.insert(np.asarray(a, float), gaps, np.nan) for a in arrays)


def _mark_gaps(ax: Any, comparison: Comparison, gaps: np.ndarray) -> None:
    """Shade the stretches of the time axis where the record was not measured."""
    x = comparison.axis
    for k in gaps:
        ax.axvspan(x[k - 1], x[k], color='tab:orange', alpha=0.15, lw=0, zorder=0)
    if gaps.size:
        ax.text(x[gaps[0] - 1], 0.0, ' not measured', transform=ax.get_xaxis_transform(),
                va='bottom', fontsize=8, color='tab:orange')


def _label(name: str, comparison: Comparison) -> str:
    """Return an axis label with the output's unit, 'position [mm]' (no unit if unknown)."""
    unit = getattr(comparison, 'unit', '')
    return f'{name} [{unit}]' if unit else name


def plot_time(comparison: Comparison, alternative: Optional[tuple] = None) -> Figure:
    """Measured and model position over time [s], validation part shaded."""
    fig, axes = _figure()
    ax = axes[0, 0]
    gaps = _gaps(comparison)
    t, measured, predicted = _broken(gaps, comparison.axis, comparison.measured,
                                     comparison.predicted)
    ax.plot(t, measured, color='k', lw=0.8, label='measured')
    ax.plot(t, predicted, color='tab:red', lw=0.9, label='model')
    if alternative is not None:
        label, pred = alternative
        ax.plot(t, *_broken(gaps, pred), color='tab:blue', lw=0.9, label=label)
    _mark_split(ax, comparison)
    _mark_gaps(ax, comparison, gaps)
    ax.set(xlabel='time [s]', ylabel=_label('position', comparison))
    ax.legend(loc='lower right', fontsize=8)
    return fig


def plot_residual(comparison: Comparison) -> Figure:
    """Residual over time (or over the sample index for static curves)."""
    fig, axes = _figure(h=3)
    ax = axes[0, 0]
    gaps = _gaps(comparison)
    ax.plot(*_broken(gaps, comparison.axis, comparison.residual), color='tab:purple', lw=0.7)
    ax.axhline(0, color='0.5', lw=0.8)
    _mark_split(ax, comparison)
    _mark_gaps(ax, comparison, gaps)
    ax.set(xlabel=comparison.axis_label, ylabel=_label('measured − model', comparison))
    return fig


def plot_hysteresis(comparison: Comparison) -> Figure:
    """Measured and model position vs model temperature difference (or duty difference)."""
    fig, axes = _figure(w=6, h=5)
    ax = axes[0, 0]
    sig = comparison.signals
    if not sig.get('proxy'):
        x, xlabel = sig['theta_a'] - sig['theta_b'], 'model wire temperature θa − θb [°C]'
    else:
        x, xlabel = sig['duty_diff'], 'duty_a − duty_b'
    x, measured, predicted = _broken(_gaps(comparison), x, comparison.measured,
                                     comparison.predicted)
    ax.plot(x, measured, color='k', lw=0.5, alpha=0.7, label='measured')
    ax.plot(x, predicted, color='tab:red', lw=0.6, alpha=0.8, label='model')
    ax.set(xlabel=xlabel, ylabel=_label('position', comparison))
    ax.legend(fontsize=8)
    return fig


def plot_curves(comparison: Comparison) -> Figure:
    """Plot static data: output vs input per curve, measured dots and model lines."""
    fig, axes = _figure(w=7, h=5)
    ax = axes[0, 0]
    u, curve = comparison.signals['input'], comparison.signals['curve']
    ids = list(dict.fromkeys(curve.tolist()))
    palette = colormaps['tab10' if len(ids) <= 10 else 'tab20']
    colours = [palette(i % palette.N) for i in range(len(ids))]
    for cid, colour in zip(ids, colours):
        m = curve == cid
        ls = '--' if cid % 2 == 1 else '-'
        ax.plot(u[m], comparison.measured[m], '.', color=colour, ms=3)
        ax.plot(u[m], comparison.predicted[m], ls, color=colour, lw=1, label=f'curve {cid}')
    ax.set(xlabel='input', ylabel='output')
    ax.legend(fontsize=7, ncol=2)
    return fig


def plot_regimes(comparison: Comparison) -> Figure:
    """Bar chart of NRMSE [%] per regime label, one panel per group; dashed: overall."""
    groups = comparison.regimes
    cols = 3
    rows = int(np.ceil(len(groups) / cols))
    fig, axes = _figure(w=11, h=2.6 * rows, rows=rows, cols=cols)
    overall = comparison.scores['all']['nrmse']
    for ax, (group, items) in zip(axes.ravel(), groups.items()):
        labels = [r['label'] for r in items]
        values = [100 * (r['nrmse'] or 0.0) for r in items]
        hot = [r in comparison.concentrated for r in items]
        ax.bar(range(len(items)), values, color=['tab:red' if h else 'tab:gray' for h in hot])
        if overall is not None:
            ax.axhline(100 * overall, color='k', ls='--', lw=0.8)
        ax.set_xticks(range(len(items)), labels, rotation=30, ha='right', fontsize=7)
        ax.set_title(group, fontsize=9)
        ax.set_ylabel('NRMSE [%]', fontsize=8)
    for ax in axes.ravel()[len(groups):]:
        ax.set_visible(False)
    return fig


# the figures a data kind can name, by file name: (comparison, alternative) -> Figure
_PLOTS = {'time.png': plot_time,
          'curves.png': lambda comparison, alternative: plot_curves(comparison),
          'residual.png': lambda comparison, alternative: plot_residual(comparison),
          'hysteresis.png': lambda comparison, alternative: plot_hysteresis(comparison)}


def plot_correlations(comparison: Comparison) -> Figure:
    """Residual autocorrelation and the strongest cross-correlations with ±band."""
    corr = comparison.correlations
    cross = sorted(corr['cross'].items(), key=lambda kv: -kv[1]['strength'])[:MAX_CROSS_PANELS]
    panels = [('residual autocorrelation', corr['autocorrelation'])] + \
        [(f'residual x {k}', v) for k, v in cross]
    cols = 3
    rows = int(np.ceil(len(panels) / cols))
    fig, axes = _figure(w=11, h=2.4 * rows, rows=rows, cols=cols)
    band = corr['band']
    step = corr['max_lag'] / max(1, np.max(np.abs(corr['autocorrelation']['lags'])))
    for ax, (name, test) in zip(axes.ravel(), panels):
        lags = np.asarray(test['lags']) * step
        ax.axhspan(-band, band, color='tab:blue', alpha=0.15, lw=0)
        ax.plot(lags, test['r'], color='tab:red' if test['exceeds'] else 'k', lw=0.9)
        ax.axhline(0, color='0.5', lw=0.5)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel(f"lag [{corr['lag_unit']}]", fontsize=8)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    return fig


# ------------------------------------------------------------------------------ HTML
STYLE = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1.5em}td,th{border:1px solid #ccc;
padding:3px 8px;text-align:right}th{background:#f0f0f0}td.l,th.l{text-align:left}
tr.hot td{background:#fde0dc}img{max-width:100%;border:1px solid #ddd}
.note{color:#555;font-size:90%}"""


def _f(x: Optional[float], fmt: str = '{:.4g}') -> str:
    """Return x formatted, 'n/a' for None."""
    return 'n/a' if x is None else fmt.format(x)


def _table(header: list, rows: list, left: int = 1, hot: Optional[list] = None) -> str:
    head = ''.join(f'<th class="l">{html.escape(h)}</th>' if i < left
                   else f'<th>{html.escape(h)}</th>' for i, h in enumerate(header))
    body = []
    for k, row in enumerate(rows):
        cells = ''.join(f'<td class="l">{html.escape(str(c))}</td>' if i < left
                        else f'<td>{html.escape(str(c))}</td>' for i, c in enumerate(row))
        cls = ' class="hot"' if hot and hot[k] else ''
        body.append(f'<tr{cls}>{cells}</tr>')
    return f'<table><tr>{head}</tr>{"".join(body)}</table>'


def _score_row(part: str, s: dict) -> list:
    # a held-out part covering under engine.MIN_COVERAGE of the range has no relative score
    if part == 'validation' and s.get('informative') is False:
        return [part, 'uninformative', _f(s['rmse']), '-', _f(s['max_error'])]
    return [part, _pct(s['nrmse']), _f(s['rmse']), _f(s['fit_percent'], '{:.1f}'),
            _f(s['max_error'])]


def _scores_html(comparison: Comparison) -> str:
    rows = [_score_row(part, s) for part, s in comparison.scores.items() if s]
    return _table(['part', 'NRMSE', _label('RMSE', comparison), 'fit %',
                   _label('max error', comparison)], rows)


def _model_html(model: Optional[dict]) -> str:
    if not model:
        return ''
    effects = ', '.join(model.get('effects') or []) or 'none (paper base model)'
    out = [f'<p>Model: <b>{html.escape(str(model.get("kind") or ""))}</b> base, effects: '
           f'<b>{html.escape(effects)}</b></p>']
    params = model.get('parameters') or {}
    scalars = [[k, _f(v)] for k, v in params.items() if isinstance(v, (int, float))]
    if scalars:
        out.append(_table(['parameter', 'value'], scalars))
    return ''.join(out)


def _regimes_html(comparison: Comparison) -> str:
    out = []
    for group, items in comparison.regimes.items():
        rows = [[r['label'], r['samples'], _pct(r['fraction']), _pct(r['nrmse']), _f(r['rmse']),
                 _f(r['bias']), _pct(r['error_share'])] for r in items]
        out.append(f'<h3>{html.escape(group)}</h3>')
        out.append(_table(['regime', 'samples', 'share of samples', 'NRMSE',
                           _label('RMSE', comparison), _label('mean error', comparison),
                           'share of squared error'], rows,
                          hot=[r in comparison.concentrated for r in items]))
    return ''.join(out)


def _tests_html(comparison: Comparison) -> str:
    corr = comparison.correlations
    unit = corr['lag_unit']
    tests = [('residual (autocorrelation)', corr['autocorrelation'])] + list(corr['cross'].items())
    rows = [[name, f"{t['max_abs']:.3f}", f"{t['at_lag']:g}", f"{t['strength']:.1f}",
             _pct(t['fraction_over']), 'yes' if t['exceeds'] else 'no'] for name, t in tests]
    note = (f'<p class="note">99 % band ±{corr["band"]:.4f} (±2.576/√N); lags up to '
            f'{corr["max_lag"]:g} {unit}; positive lag: the signal leads the residual. '
            'The band assumes a white residual; strength = max|r| / band ranks the signals.'
            + (f' Constant, not tested: {html.escape(", ".join(corr["untested"]))}.'
               if corr['untested'] else '') + '</p>')
    return note + _table(['signal', 'max |r|', f'at lag [{unit}]', 'strength',
                          'lags over band', 'exceeds band'], rows,
                         hot=[t['exceeds'] for _, t in tests])


def _diagnosis_html(diagnosis: Optional[dict]) -> str:
    if not diagnosis:
        return ''
    base = diagnosis['baseline']
    missing = diagnosis.get('missing_effect')
    floor = base.get('noise_floor_nrmse')
    head = (f'<p>Baseline effects: <b>{html.escape(", ".join(base["effects"]) or "none")}'
            f'</b>, validation NRMSE {_pct(base["validation_nrmse"])}'
            + (f' (the measurement noise alone: {_pct(floor)})' if floor else '')
            + '. Missing effect: '
            f'<b>{html.escape(missing) if missing else "none found (no candidate is significant)"}'
            '</b></p>'
            + ''.join(f'<p>{html.escape(line)}</p>' for line in remaining_lines(diagnosis)))
    rows = [[c['effect'], _pct(c['validation_nrmse']), _pct(c['improvement']),
             'yes' if c['significant'] else 'no', c.get('explanation', '')]
            for c in diagnosis['candidates']]
    return '<h2>Diagnosis: candidate effects, best first</h2>' + head + _table(
        ['effect', 'validation NRMSE', 'improvement', 'significant', 'explanation'], rows,
        hot=[c['significant'] for c in diagnosis['candidates']]) + _rounds_html(diagnosis)


def _rounds_html(diagnosis: dict) -> str:
    # the rounds of `diagnose --rounds`, as the command prints them: the error falling round
    # by round and what the final model leaves over the noise
    if not diagnosis.get('rounds'):
        return ''
    lines = rounds_lines(diagnosis, diagnosis.get('rounds_limit', len(diagnosis['rounds'])))
    return '<pre>' + html.escape('\n'.join(lines)) + '</pre>'


def render_html(comparison: Comparison, title: str, data_line: str, model: Optional[dict],
                diagnosis: Optional[dict], figures: list) -> str:
    """Return the report page as a string (figures: [(file, caption, fig)])."""
    imgs = ''.join(f'<h3>{html.escape(cap)}</h3><img src="{name}" alt="{html.escape(cap)}">'
                   for name, cap, _ in figures)
    parts = [f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>{html.escape(title)}'
             f'</title><style>{STYLE}</style></head><body>',
             f'<h1>{html.escape(title)}</h1>',
             f'<p>{html.escape(data_line)}</p>' if data_line else '',
             _model_html(model),
             '<h2>Scores (free-run simulation)</h2>', _scores_html(comparison),
             '<p class="note">NRMSE = RMSE / range of the measured output; fit % = 100 (1 − '
             '‖e‖/‖y − ȳ‖).</p>',
             _diagnosis_html(diagnosis),
             '<h2>Figures</h2>', imgs,
             f'<h2>Error by regime</h2><p class="note">Highlighted: RMSE at least '
             f'{CONCENTRATION_RATIO:g} x the overall RMSE on at least {100 * MIN_SHARE:g} % of '
             'the samples.</p>', _regimes_html(comparison),
             '<h2>Residual tests</h2>', _tests_html(comparison),
             '</body></html>']
    return '\n'.join(p for p in parts if p)
