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
The fleet table and its HTML index, from the per-record results of `batch`.

Files written into the batch directory (each replaced atomically):

* ``batch.parquet``, ``batch.csv``  one row per record (columns below)
* ``index.html``                    fleet summary and a link to every record's report
* ``parameters.png``                spread of the fitted parameters across records

NRMSE columns are fractions of the record's measured output range (0.01 = 1 %);
parameter columns are ``param.<name>`` with the unit in the name (``param.delay_s``).
"""
from __future__ import annotations

from collections import Counter
import html
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

COLUMNS = ('record', 'layout', 'samples', 'duration_s', 'rate_hz', 'position_unit',
           'reference_nrmse', 'lead_in_duty_a', 'lead_in_duty_b', 'lead_in_first_duties_s',
           'base_effects', 'base_train_nrmse', 'base_validation_nrmse',
           'noise_floor_nrmse', 'named_effect', 'improvement', 'effects_added',
           'final_validation_nrmse', 'training_lead', 'task_time_s', 'wall_time_s', 'report',
           'notes', 'error')
TEXT_COLUMNS = ('record', 'layout', 'position_unit', 'base_effects', 'named_effect',
                'effects_added', 'training_lead', 'report', 'notes', 'error')
INTEGER_COLUMNS = ('samples',)
PARAMETER_PREFIX = 'param.'


def table_rows(results: Sequence[Dict[str, Any]]) -> List[Dict[str, Any]]:
    """Return flat rows (one per record, sorted by record path) with a column per parameter."""
    names = sorted({k for r in results for k in (r.get('parameters') or {})})
    rows = []
    for r in sorted(results, key=lambda r: r['record']):
        row = {c: r.get(c) for c in COLUMNS}
        params = r.get('parameters') or {}
        row.update({PARAMETER_PREFIX + n: params.get(n) for n in names})
        rows.append(row)
    return rows


def write_table(out_dir: Union[str, Path],
                results: Sequence[Dict[str, Any]]) -> Tuple[Path, Path]:
    """Write batch.parquet and batch.csv; return their paths."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq
    rows = table_rows(results)
    columns = list(COLUMNS) + sorted({k for row in rows for k in row} - set(COLUMNS))
    schema = pa.schema([(c, pa.int64() if c in INTEGER_COLUMNS else pa.string()
                         if c in TEXT_COLUMNS else pa.float64()) for c in columns])
    table = pa.Table.from_pylist([{c: row.get(c) for c in columns} for row in rows],
                                 schema=schema)
    out_dir = Path(out_dir)
    paths = (out_dir / 'batch.parquet', out_dir / 'batch.csv')
    for path, write in zip(paths, (pq.write_table, pacsv.write_csv)):
        tmp = path.with_name(path.name + '.tmp')
        write(table, tmp)
        tmp.replace(path)
    return paths


def plot_parameters(out_dir: Union[str, Path],
                    rows: Sequence[Dict[str, Any]]) -> Optional[Path]:
    """Write the strip plot of every fitted parameter across records; None if none."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    names = [c for c in (rows[0] if rows else {}) if c.startswith(PARAMETER_PREFIX)]
    series = {n: np.array([r[n] for r in rows if r.get(n) is not None], float) for n in names}
    series = {n: v for n, v in series.items() if v.size}
    if not series:
        return None
    cols = min(4, len(series))
    nrows = -(-len(series) // cols)
    fig = Figure(figsize=(3.2 * cols, 2.6 * nrows))
    FigureCanvasAgg(fig)
    rng = np.random.default_rng(0)
    for i, (name, values) in enumerate(series.items()):
        ax = fig.add_subplot(nrows, cols, i + 1)
        ax.boxplot(values, widths=0.5, showfliers=False)
        ax.plot(1 + rng.uniform(-0.15, 0.15, values.size), values, '.', alpha=0.6)
        ax.set_title(f'{name[len(PARAMETER_PREFIX):]} (n = {values.size})', fontsize=9)
        ax.set_xticks([])
    fig.suptitle('fitted parameters across records (unit in each name)')
    fig.tight_layout()
    path = Path(out_dir) / 'parameters.png'
    tmp = path.with_name('parameters.tmp.png')
    fig.savefig(tmp, dpi=90)
    tmp.replace(path)
    return path


def effect_recurrence(rows: Sequence[Dict[str, Any]]) -> Dict[str, List[str]]:
    """Return {effect: [records where it was named]} over every round, most frequent first."""
    where = {}
    for row in rows:
        for name in (row.get('effects_added') or '').split():
            where.setdefault(name, []).append(row['record'])
    counts = Counter({k: len(v) for k, v in where.items()})
    return {k: where[k] for k, _ in counts.most_common()}


def _pct(x: Optional[float]) -> str:
    """Return the fraction x as a percentage text ('' for None)."""
    return '' if x is None else f'{100 * x:.2f} %'


def write_index(out_dir: Union[str, Path], results: Sequence[Dict[str, Any]],
                title: str = 'sma-model batch') -> Path:
    """Write index.html (fleet summary, effect recurrence, a row per record); return it."""
    rows = table_rows(results)
    plot = plot_parameters(out_dir, [r for r in rows if not r['error']])
    failed = [r for r in rows if r['error']]
    esc = html.escape
    recurrence = effect_recurrence(rows)
    parts = [f'<!doctype html><meta charset="utf-8"><title>{esc(title)}</title>',
             '<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}'
             'td,th{border:1px solid #ccc;padding:2px 6px;font-size:90%}'
             '.err{background:#fdd}</style>',
             f'<h1>{esc(title)}</h1>',
             f'<p>{len(rows)} records, {len(rows) - len(failed)} fitted, {len(failed)} '
             'failed. NRMSE: RMS error as a percentage of the record’s measured output '
             'range; validation = the held-out part of each record.</p>',
             '<h2>Effects named</h2>']
    if recurrence:
        parts.append('<table><tr><th>effect</th><th>records</th><th>where</th></tr>')
        for name, where in recurrence.items():
            links = ', '.join(esc(Path(w).name) for w in where)
            parts.append(f'<tr><td>{esc(name)}</td><td>{len(where)}</td><td>{links}</td></tr>')
        parts.append('</table>')
    else:
        parts.append('<p>No record has a significant missing effect.</p>')
    if plot:
        parts.append(f'<h2>Fitted parameters</h2><img src="{plot.name}" alt="parameter spread">')
    head = ('record', 'layout', 'samples', 'base validation NRMSE', 'effects named',
            'final validation NRMSE', 'time [s]', 'notes', 'report / error')
    parts.append('<h2>Records</h2><table><tr>' + ''.join(f'<th>{h}</th>' for h in head)
                 + '</tr>')
    for r in rows:
        last = (f'<a href="{esc(r["report"])}">report</a>' if r['report'] else
                esc(r['error'] or ''))
        cells = (esc(Path(r['record']).name), esc(r['layout'] or ''), r['samples'] or '',
                 _pct(r['base_validation_nrmse']), esc(r['effects_added'] or ''),
                 _pct(r['final_validation_nrmse']),
                 '' if r['task_time_s'] is None else f'{r["task_time_s"]:.1f}',
                 esc(r['notes'] or ''), last)
        cls = ' class="err"' if r['error'] else ''
        parts.append(f'<tr{cls}>' + ''.join(f'<td>{c}</td>' for c in cells) + '</tr>')
    parts.append('</table>')
    path = Path(out_dir) / 'index.html'
    tmp = path.with_name('index.html.tmp')
    tmp.write_text('\n'.join(parts), encoding='utf-8')
    tmp.replace(path)
    return path
