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
`sma-model`: fit, compare and diagnose actuator models on recorded data.

    sma-model fit DATA [--model MODEL.yaml] [--add EFFECT ...] [--out FITTED.yaml] [--json]
    sma-model compare DATA --model FITTED.yaml [--report DIR] [--json]
    sma-model diagnose DATA [--model MODEL.yaml] [--report DIR] [--json]
    sma-model batch DATA... --out DIR [--model MODEL.yaml] [--rounds N] [--scheduler ADDRESS]
    sma-model effects [--json]        (the catalog, with plug-ins)

Every command also takes --plugin FILE.py|MODULE (repeatable) to add user effects, and
--force to overwrite existing output files. Bad input ends with exit code 2 and one line
``sma-model: error: ...`` on stderr, before any output file is written. Progress goes to
stderr: a bar on a terminal, otherwise plain lines for long stages and large files. See
docs/workbench.md.
"""
import argparse
import json
import os
from pathlib import Path
import sys
import time

import numpy as np

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
PROG = 'sma-model'


class UsageError(ValueError):
    """Bad command-line input (reported as one line, exit code 2)."""


class OneLineParser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line `sma-model: error: ...` and exit code 2."""

    def error(self, message):
        """Print the one-line error and exit 2 (argparse's default prints the usage too)."""
        self.exit(EXIT_BAD_INPUT, f'{PROG}: error: {message} (see {self.prog} --help)\n')


# ------------------------------------------------------------------------------ progress
class Progress:
    """
    Progress bar on stderr, drawn only when stderr is a terminal (callable for the engine).

    Called as progress(done, total, label); `close()` clears the line.
    """

    WIDTH = 24

    #: Without a terminal: plain lines, one per 10 %, once a stage has run this long [s].
    LOG_AFTER_S = 5.0

    def __init__(self, stage='', stream=None):
        self.stream = stream or sys.stderr
        self.enabled = bool(getattr(self.stream, 'isatty', lambda: False)())
        self.stage = stage
        self.drawn = False
        self.started = time.monotonic()
        self.logged = (None, -1)  # (stage, tenths) of the last logged line

    def _log(self, done, total, label):
        """Print a plain progress line (for logs) each 10 % of a long-running stage."""
        elapsed = time.monotonic() - self.started
        tenths = int(10 * done / total) if total else 10
        if elapsed < self.LOG_AFTER_S or self.logged == (self.stage, tenths):
            return
        self.logged = (self.stage, tenths)
        self.stream.write(f'{PROG}: {self.stage} {10 * tenths} % ({done}/{total} {label}, '
                          f'{elapsed:.0f} s)\n')
        self.stream.flush()

    def __call__(self, done, total, label=''):
        if not self.enabled:
            self._log(done, total, label)
            return
        frac = min(max(done / total, 0.0), 1.0) if total else 1.0
        bar = '#' * int(round(frac * self.WIDTH))
        self.stream.write(f'\r\033[K{self.stage} [{bar:<{self.WIDTH}}] {done}/{total} {label}')
        self.stream.flush()
        self.drawn = True

    def close(self):
        """Erase the bar line."""
        if self.drawn:
            self.stream.write('\r\033[K')
            self.stream.flush()
            self.drawn = False


def _note(args, text):
    """Human-readable line: stdout normally, stderr with --json (stdout holds the JSON)."""
    print(text, file=sys.stderr if args.json else sys.stdout)


# ------------------------------------------------------------------------------ shared steps
def setup_effects(args):
    """Load entry-point and --plugin effects; returns the catalog."""
    from . import plugins
    from .effects import CATALOG
    plugins.load_entry_points()
    plugins.load_plugins(args.plugin or [])
    return CATALOG


def check_outputs_spare_data(args):
    """Raise UsageError if --out or --report would write over DATA itself (even with --force)."""
    data = Path(args.data).resolve()
    for option, target in (('--out', getattr(args, 'out', None)),
                           ('--report', getattr(args, 'report', None))):
        if target and Path(target).resolve() == data:
            raise UsageError(f'{option} {target} is DATA itself; choose another path')


def check_effect_names(names, catalog, what='--add'):
    """Raise UsageError for names not in the catalog."""
    unknown = [n for n in names if n not in catalog]
    if unknown:
        raise UsageError(f'{what}: unknown effect(s) {", ".join(unknown)}; known: '
                         f'{", ".join(sorted(catalog))}')


def load_checked_data(args):
    """Load DATA and require enough excitation; returns the data object."""
    from .data import check_excitation, load_data
    data = load_data(args.data, rate_hz=args.rate)
    check_excitation(data, args.data)
    return data


def read_model_spec(path, catalog):
    """MODEL.yaml as a checked dict (effects known to the catalog)."""
    from .modelfile import read_model
    return read_model(path, known_effects=catalog)


def model_signals(fit, data):
    """Model wire temperatures for the comparison: the fit's, or re-simulated, or none."""
    if fit.signals:
        return fit.signals
    params = getattr(fit, 'params', None)
    if hasattr(params, 'hysteresis') and hasattr(data, 'duty_a'):
        from ..core.actuator import simulate
        tr = simulate(params, data.duty_a, data.duty_b, data.dt, ambient_c=data.ambient)
        return {'theta_a': tr.theta_a_c, 'theta_b': tr.theta_b_c}
    return {}


def json_safe(obj):
    """Plain JSON data: numpy -> Python, non-finite floats -> None."""
    from .modelfile import to_plain
    obj = to_plain(obj)
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [json_safe(v) for v in obj]
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def print_json(obj):
    """Print strict JSON (no NaN) to stdout."""
    print(json.dumps(json_safe(obj), indent=2, allow_nan=False))


def _pct(x):
    return 'n/a' if x is None else f'{100 * x:.2f} %'


def score_line(part, s):
    """Return 'validation: NRMSE 1.23 %  RMSE ...' for a scores dict (or n/a)."""
    if not s:
        return f'{part:>10}: n/a'
    return (f'{part:>10}: NRMSE {_pct(s["nrmse"])}  RMSE {s["rmse"]:.4g}  fit '
            f'{s["fit_percent"]:.1f} %  max error {s["max_error"]:.4g}')


def model_line(effects, kind):
    """Return 'modified PI base + saturation, delay' ('... (the paper's model)' if none)."""
    if effects:
        return f'{kind} PI base + {", ".join(effects)}'
    return f'{kind} PI base' + (" (the paper's model)" if kind == 'modified' else '')


# ------------------------------------------------------------------------------ fit
def cmd_fit(args):
    """sma-model fit: fit the base model plus effects; print scores; write FITTED.yaml."""
    from .data import describe
    from .engine import fit_model
    from .modelfile import check_writable, write_model
    catalog = setup_effects(args)
    check_outputs_spare_data(args)
    if args.out:
        check_writable(args.out, args.force)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    add = args.add or []
    check_effect_names(add, catalog)
    effects = list(dict.fromkeys(spec['effects'] + add))
    kind = args.kind or spec.get('kind')
    data = load_checked_data(args)
    _note(args, f'{args.data}: {describe(data)}')
    progress = Progress('fit')
    try:
        fit = fit_model(data, effects=tuple(effects), kind=kind, progress=progress)
    finally:
        progress.close()
    if args.out:
        write_model(args.out, fit.to_dict(), force=args.force)
    if args.json:
        print_json(fit_json(fit, args.out))
    else:
        print(f'model: {model_line(fit.effects, fit.kind)} ({fit.n_parameters} parameters)')
        if fit.values:
            print('fitted: ' + ', '.join(f'{k} = {v:.4g}' for k, v in fit.values.items()))
        print(score_line('train', fit.train))
        print(score_line('validation', fit.validation))
    if args.out:
        _note(args, f'wrote {args.out}')
    return 0


def fit_json(fit, out):
    """Return the `fit --json` document."""
    val = fit.validation or {}
    return {'effects': list(fit.effects), 'kind': fit.kind,
            'train_nrmse': fit.train['nrmse'], 'validation_nrmse': val.get('nrmse'),
            'parameters': dict(fit.values), 'n_parameters': fit.n_parameters,
            'train': fit.train, 'validation': fit.validation,
            'out': str(out) if out else None}


# ------------------------------------------------------------------------------ compare
def cmd_compare(args):
    """sma-model compare: score a fitted model on DATA, break the error down, test residual."""
    from .compare import compare, summary_lines
    from .data import describe, is_static
    from .engine import load_fit
    from .modelfile import is_fitted, is_static_model
    from .report import check_report_dir
    catalog = setup_effects(args)
    check_outputs_spare_data(args)
    if args.report:
        check_report_dir(args.report, args.force)
    spec = read_model_spec(args.model, catalog)
    if not is_fitted(spec):
        raise UsageError(f'{args.model}: holds no fitted model (no "model" section); run '
                         f'{PROG} fit DATA --out FITTED.yaml first')
    data = load_checked_data(args)
    if is_static_model(spec) != is_static(data):
        kinds = ('static curves', 'a dynamic record')
        raise UsageError(f'{args.model} was fitted on {kinds[not is_static_model(spec)]} but '
                         f'{args.data} is {kinds[not is_static(data)]}')
    try:
        fit = load_fit(spec, data=data)
    except (KeyError, TypeError, ValueError) as err:
        what = f'missing {err}' if isinstance(err, KeyError) else str(err)
        raise UsageError(f'{args.model}: cannot use the fitted model ({what})') from None
    result = compare(data, fit.prediction, model_signals(fit, data))
    title = f'{PROG} compare: {args.data} with {args.model}'
    if args.report:
        _write_report(args, result, title, describe(data), spec)
    if args.json:
        print_json({'data': str(args.data), 'model': {'effects': spec['effects'],
                                                      'kind': spec.get('kind')}}
                   | result.to_json())
    else:
        print(f'{args.data}: {describe(data)}')
        print(f'model: {model_line(spec["effects"], spec.get("kind") or "modified")}')
        print('\n'.join(summary_lines(result)))
    return 0


def _write_report(args, comparison, title, data_line, model, diagnosis=None, alternative=None):
    from .report import write_report
    index = write_report(args.report, comparison, title, data_line=data_line, model=model,
                         diagnosis=diagnosis, alternative=alternative, force=args.force)
    _note(args, f'report: {index}')


# ------------------------------------------------------------------------------ diagnose
def cmd_diagnose(args):
    """sma-model diagnose: refit with each candidate effect, rank by held-out improvement."""
    from .data import describe
    from .engine import diagnose, fit_model
    from .report import check_report_dir
    catalog = setup_effects(args)
    check_outputs_spare_data(args)
    if args.report:
        check_report_dir(args.report, args.force)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    if args.candidates:
        check_effect_names(args.candidates, catalog, '--candidates')
    kind = args.kind or spec.get('kind')
    data = load_checked_data(args)
    _note(args, f'{args.data}: {describe(data)}')
    progress = Progress('base fit')
    try:
        base = fit_model(data, effects=tuple(spec['effects']), kind=kind, progress=progress)
        progress.stage = 'diagnose'
        diag = diagnose(data, base=base, candidates=args.candidates, progress=progress,
                        jobs=args.jobs)
    finally:
        progress.close()
    doc = diag.to_json()
    if args.report:
        from .report import write_diagnosis_report
        index = write_diagnosis_report(args.report, data, diag, f'{PROG} diagnose: {args.data}',
                                       describe(data), force=args.force)
        _note(args, f'report: {index}')
    if args.json:
        print_json(doc)
    else:
        print('\n'.join(diagnosis_lines(doc, base.kind)))
    return 0


def diagnosis_lines(doc, kind):
    """Text table of a diagnosis document, best candidate first."""
    base = doc['baseline']
    lines = [f'baseline: {model_line(base["effects"], kind)}, validation NRMSE '
             f'{_pct(base["validation_nrmse"])}',
             f'{"effect":<20} {"val. NRMSE":>10} {"improvement":>11}  significant']
    for c in doc['candidates']:
        imp = 'n/a' if c['improvement'] is None else f'{100 * c["improvement"]:+.0f} %'
        lines.append(f'{c["effect"]:<20} {_pct(c["validation_nrmse"]):>10} {imp:>11}  '
                     f'{"yes" if c["significant"] else "no"}')
    missing = doc['missing_effect']
    lines.append(f'missing effect: {missing}' if missing else
                 'missing effect: none (no candidate cuts the held-out error clearly)')
    if missing:
        c = next(c for c in doc['candidates'] if c['effect'] == missing)
        lines.append(f'  {c["explanation"]}')
        lines.append(f'  next: {PROG} fit DATA --add {missing} ... --out FITTED.yaml')
    return lines


# ------------------------------------------------------------------------------ batch
def cmd_batch(args):
    """sma-model batch: fit, compare and diagnose every record on a Dask cluster."""
    from .batch import BatchOptions, BatchProgress, find_records, run_batch, start_client
    from .fleet import write_index, write_table
    catalog = setup_effects(args)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    if args.candidates:
        check_effect_names(args.candidates, catalog, '--candidates')
    paths = find_records(args.data)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f'--out {out}: exists and is not a directory')
    if any(out.resolve() == p for p in paths):
        raise UsageError(f'--out {out} is one of the records; choose another path')
    out.mkdir(parents=True, exist_ok=True)
    from .modelfile import is_fitted
    options = BatchOptions(effects=tuple(spec['effects']), kind=args.kind or spec.get('kind'),
                           candidates=tuple(args.candidates) if args.candidates else None,
                           rounds=args.rounds, rate_hz=args.rate, reports=not args.no_reports,
                           reference=json_safe(spec) if is_fitted(spec) else None)
    _note(args, f'batch: {len(paths)} records -> {out}')
    results = []
    client = start_client(args.scheduler, args.workers)
    try:
        run_batch(paths, out, options, client, force=args.force,
                  progress=BatchProgress(len(paths)), results=results)
    except KeyboardInterrupt:
        write_table(out, results)
        write_index(out, results)
        print(f'{PROG}: interrupted; {out / "batch.parquet"} holds the {len(results)} of '
              f'{len(paths)} records finished so far (rerun to continue)', file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        _close_client(client)
    table, _ = write_table(out, results)
    index = write_index(out, results)
    failed = sum(1 for r in results if r['error'])
    if args.json:
        print_json({'out': str(out), 'records': len(results), 'errors': failed,
                    'table': str(table), 'index': str(index),
                    'named': {Path(r['record']).name: r['effects_added'] for r in results}})
    else:
        print(f'{len(results)} records, {failed} errors; table {table}; index {index}')
    return 0


def _close_client(client):
    """Close the client and, if it started one, its local cluster."""
    cluster = client.cluster
    client.close()
    if cluster is not None:
        cluster.close()


# ------------------------------------------------------------------------------ effects
def cmd_effects(args):
    """sma-model effects: list the catalog (with plug-ins): parameters, signature, physics."""
    catalog = setup_effects(args)
    doc = [{'effect': name, 'parameters': {k: list(v[:2]) for k, v in e.parameters.items()},
            'needs_dynamic': bool(e.needs_dynamic), 'signature': e.signature, 'physics': e.doc}
           for name, e in catalog.items()]
    if args.json:
        print_json(doc)
        return 0
    for d in doc:
        bounds = ', '.join(f'{k} in [{lo:g}, {hi:g}]' for k, (lo, hi) in d['parameters'].items())
        print(f'{d["effect"]}: {bounds or "no free parameter"}')
        print(f'    physics:   {d["physics"]}')
        print(f'    signature: {d["signature"]}')
    return 0


# ------------------------------------------------------------------------------ parser
def build_parser():
    """Return the argparse parser of `sma-model` (one-line errors, exit code 2)."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument('data', metavar='DATA',
                        help='CSV (dynamic or static curves) or MCAP bag (file or directory)')
    common.add_argument('--plugin', action='append', metavar='FILE.py|MODULE',
                        help='load user effects from a Python file or module (repeatable)')
    common.add_argument('--json', action='store_true', help='print the result as JSON')
    common.add_argument('--force', action='store_true', help='overwrite existing output files')
    common.add_argument('--rate', type=_positive_float, metavar='HZ',
                        help='resampling rate for MCAP bags [Hz] (default: joint-state rate)')
    parser = OneLineParser(prog=PROG, description='Compare the SMA actuator model with '
                           'measurements, find the missing physical effect, add it.')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND',
                                parser_class=OneLineParser)
    fit = sub.add_parser('fit', parents=[common], help='fit a model, print scores',
                         description='Fit the base model plus effects to DATA.')
    fit.add_argument('--model', metavar='MODEL.yaml', help='effects (and kind) to start from')
    fit.add_argument('--add', nargs='+', action='extend', metavar='EFFECT',
                     help='effects to add to the model')
    fit.add_argument('--kind', choices=('classical', 'modified'),
                     help='hysteresis base (default: from MODEL.yaml, else modified)')
    fit.add_argument('--out', metavar='FITTED.yaml', help='write the fitted model')
    fit.set_defaults(func=cmd_fit)
    cmp_ = sub.add_parser('compare', parents=[common], help='where a fitted model fails',
                          description='Score a fitted model on DATA, break the error down '
                          'by regime and test the residual.')
    cmp_.add_argument('--model', required=True, metavar='FITTED.yaml',
                      help='fitted model (from fit --out)')
    cmp_.add_argument('--report', metavar='DIR', help='write an HTML report with figures')
    cmp_.set_defaults(func=cmd_compare)
    dia = sub.add_parser('diagnose', parents=[common], help='find the missing effect',
                         description='Refit with each candidate effect and rank them by '
                         'held-out error reduction.')
    dia.add_argument('--model', metavar='MODEL.yaml', help='base model (default: paper model)')
    dia.add_argument('--kind', choices=('classical', 'modified'),
                     help='hysteresis base (default: from MODEL.yaml, else modified)')
    dia.add_argument('--candidates', nargs='+', action='extend', metavar='EFFECT',
                     help='only try these effects (default: every catalog effect)')
    dia.add_argument('--report', metavar='DIR', help='write an HTML report with figures')
    dia.add_argument('--jobs', type=_non_negative_int, default=0, metavar='N',
                     help='processes for the candidate refits (default 0: every core)')
    dia.set_defaults(func=cmd_diagnose)
    bat = sub.add_parser('batch', help='fit, compare and diagnose many records (Dask)',
                         description='Run fit, compare and diagnose on every record, on a '
                         'Dask cluster; write a table (Parquet, CSV) and an HTML index.')
    bat.add_argument('data', nargs='+', metavar='DATA',
                     help='CSV files, MCAP bags, directories or globs')
    bat.add_argument('--out', required=True, metavar='DIR',
                     help='output directory (results are resumed from it)')
    bat.add_argument('--model', metavar='MODEL.yaml',
                     help='effects (and kind) to start from; a fitted model (fit --out) is '
                     'also compared with every record (column reference_nrmse)')
    bat.add_argument('--kind', choices=('classical', 'modified'),
                     help='hysteresis base (default: from MODEL.yaml, else modified)')
    bat.add_argument('--candidates', nargs='+', action='extend', metavar='EFFECT',
                     help='only try these effects (default: every catalog effect)')
    bat.add_argument('--rounds', type=_positive_int, default=1, metavar='N',
                     help='diagnose rounds: add the named effect and diagnose again (default 1)')
    bat.add_argument('--scheduler', metavar='ADDRESS',
                     help='a running Dask scheduler, e.g. tcp://10.0.0.5:8786 '
                     '(default: a local cluster on every core)')
    bat.add_argument('--workers', type=_positive_int, metavar='N',
                     help='local cluster size in processes (default: every core)')
    bat.add_argument('--rate', type=_positive_float, metavar='HZ',
                     help='resampling rate for MCAP bags [Hz] (default: joint-state rate)')
    bat.add_argument('--no-reports', action='store_true', help='skip the per-record reports')
    bat.add_argument('--force', action='store_true', help='recompute finished records')
    bat.add_argument('--json', action='store_true', help='print a JSON summary')
    bat.set_defaults(func=cmd_batch, plugin=None)
    eff = sub.add_parser('effects', help='list the effect catalog (with plug-ins)',
                         description='List every effect: parameters, physics, signature.')
    eff.add_argument('--plugin', action='append', metavar='FILE.py|MODULE',
                     help='load user effects from a Python file or module (repeatable)')
    eff.add_argument('--json', action='store_true', help='print the catalog as JSON')
    eff.set_defaults(func=cmd_effects)
    return parser


def _positive_float(text):
    from .limits import MAX_RATE_HZ, MIN_RATE_HZ, parse_number
    try:
        value = parse_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text[:40]!r} is not a number') from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f'{text!r} is not a positive number')
    if not MIN_RATE_HZ <= value <= MAX_RATE_HZ:
        raise argparse.ArgumentTypeError(f'{text} Hz is outside {MIN_RATE_HZ:g} to '
                                         f'{MAX_RATE_HZ:g} Hz')
    return value


def _positive_int(text):
    value = _non_negative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f'{text!r} is not a positive integer')
    return value


def _non_negative_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not an integer') from None
    if value < 0:
        raise argparse.ArgumentTypeError(f'{text!r} is negative')
    return value


def error_text(err):
    """One line for an input error (OSError: file and reason)."""
    if isinstance(err, OSError) and err.strerror:
        text = f'{err.filename}: {err.strerror}' if err.filename else err.strerror
    else:
        text = str(err) or type(err).__name__
    return ' '.join(text.split())


def main(argv=None):
    """Entry point of `sma-model`; returns the exit code (0 ok, 2 bad input, 130 interrupt)."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except BrokenPipeError:   # stdout closed early (e.g. piped into head): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (ValueError, OSError) as err:
        print(f'{PROG}: error: {error_text(err)}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f'{PROG}: interrupted', file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == '__main__':
    sys.exit(main())
