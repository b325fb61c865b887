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

    sma-model fit DATA [DATA ...] [--model MODEL.yaml] [--add EFFECT ...] [--out FITTED.yaml]
    sma-model compare DATA [DATA ...] --model FITTED.yaml [--report DIR] [--json]
    sma-model diagnose DATA [DATA ...] [--model MODEL.yaml] [--rounds N] [--report DIR]
    sma-model batch DATA... --out DIR [--model MODEL.yaml] [--rounds N] [--scheduler ADDRESS]
    sma-model effects [--json]        (the catalog, with plug-ins)

Every command also takes --plugin FILE.py|MODULE (repeatable) to add user effects, and
--force to overwrite existing output files; DATA commands take --validate-on DATA ...,
--layout single|antagonistic and --position-unit UNIT. Bad input ends with exit code 2 and one line
``sma-model: error: ...`` on stderr, before any output file is written. Progress goes to
stderr: a bar on a terminal, otherwise plain lines for long stages and large files. See
docs/workbench.md.
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import sys
import time
from typing import Any, Callable, Dict, IO, List, Mapping, Optional, Sequence, Tuple

from .parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads: a fit must not depend on --jobs
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)

import numpy as np  # noqa: E402, I100

from .limits import MAX_FIT_RATE_HZ  # noqa: E402, I100
from .remaining import (noise_line, percent as _pct, PROG, remaining_lines,  # noqa: E402
                        rounds_lines)
from ..core.datakinds import DynamicData, Split, StaticData  # noqa: E402

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
# the role of each record `compare` scores: neither trained on nor held out by it
COMPARED = 'compared'
MAX_RATE_HELP = ('records sampled faster are decimated to this rate or below for fitting '
                 '(duty: block means; position: means centred on each kept sample) [Hz] '
                 '(default: %(default)g)')


class UsageError(ValueError):
    """Bad command-line input (reported as one line, exit code 2)."""


class OneLineParser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line `sma-model: error: ...` and exit code 2."""

    def error(self, message: str) -> None:
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

    def __init__(self, stage: str = '', stream: Optional[IO[str]] = None):
        self.stream = stream or sys.stderr
        self.enabled = bool(getattr(self.stream, 'isatty', lambda: False)())
        self.stage = stage
        self.drawn = False
        self.started = time.monotonic()
        self.logged = (None, -1)  # (stage, tenths) of the last logged line

    def _log(self, done: int, total: int, label: str) -> None:
        """Print a plain progress line (for logs) each 10 % of a long-running stage."""
        elapsed = time.monotonic() - self.started
        tenths = int(10 * done / total) if total else 10
        if elapsed < self.LOG_AFTER_S or self.logged == (self.stage, tenths):
            return
        self.logged = (self.stage, tenths)
        self.stream.write(f'{PROG}: {self.stage} {10 * tenths} % ({done}/{total} {label}, '
                          f'{elapsed:.0f} s)\n')
        self.stream.flush()

    def __call__(self, done: int, total: int, label: str = '') -> None:
        """Draw the bar at done of total (plain lines instead without a terminal)."""
        if not self.enabled:
            self._log(done, total, label)
            return
        frac = min(max(done / total, 0.0), 1.0) if total else 1.0
        bar = '#' * int(round(frac * self.WIDTH))
        self.stream.write(f'\r\033[K{self.stage} [{bar:<{self.WIDTH}}] {done}/{total} {label}')
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        """Erase the bar line."""
        if self.drawn:
            self.stream.write('\r\033[K')
            self.stream.flush()
            self.drawn = False


def _note(args: argparse.Namespace, text: str) -> None:
    """Print a human-readable line: stdout normally, stderr with --json (stdout holds the JSON)."""
    print(text, file=sys.stderr if args.json else sys.stdout)


# ------------------------------------------------------------------------------ shared steps
def setup_effects(args: argparse.Namespace) -> Dict[str, Any]:
    """Load entry-point and --plugin effects; return the catalog (name -> effect)."""
    from . import plugins
    from .effects import CATALOG
    plugins.load_entry_points()
    plugins.load_plugins(args.plugin or [])
    return CATALOG


def check_outputs_spare_data(args: argparse.Namespace) -> None:
    """Raise UsageError if --out or --report would write over DATA itself (even with --force)."""
    inputs = {Path(d).resolve() for d in all_data(args)}
    for option, target in (('--out', getattr(args, 'out', None)),
                           ('--report', getattr(args, 'report', None))):
        if target and Path(target).resolve() in inputs:
            raise UsageError(f'{option} {target} is DATA itself; choose another path')


def all_data(args: argparse.Namespace) -> List[str]:
    """Return every DATA path of the command line: DATA, then --validate-on ones not in it."""
    extra = [v for v in (getattr(args, 'validate_on', None) or []) if v not in args.data]
    return list(args.data) + extra


def check_effect_names(names: Sequence[str], catalog: Mapping[str, Any],
                       what: str = '--add') -> None:
    """Raise UsageError for names not in the catalog."""
    unknown = [n for n in names if n not in catalog]
    if unknown:
        raise UsageError(f'{what}: unknown effect(s) {", ".join(unknown)}; known: '
                         f'{", ".join(sorted(catalog))}')


def load_checked_records(args: argparse.Namespace,
                         spec: Optional[Mapping[str, Any]] = None) -> List[Tuple[str, Any]]:
    """
    Load and check every DATA record; return [(path, data)], the --layout applied.

    Mixed static and dynamic records, several static files, and records that cannot be
    fitted together are bad input. A record that names no position unit takes the unit of
    the model file `spec` (--model) or the one unit the other records name
    (`adopt_stated_unit`).
    """
    from .data import apply_layout, check_excitation, load_data
    from .records import at_fit_rate
    paths = all_data(args)
    seen = {}
    for path in paths:
        key = Path(path).resolve()
        if key in seen:
            raise UsageError(f'{path}: the same record as {seen[key]}; give each record once')
        seen[key] = path
    unit = getattr(args, 'position_unit', None)
    renames = _column_renames(args)
    loaded = []
    for path in paths:
        notes = []
        d, note = at_fit_rate(load_data(path, rate_hz=args.rate, position_unit=unit,
                                        notes=notes, default_unit='', renames=renames,
                                        keep_glitches=args.keep_glitches), args.max_rate)
        for line in notes + ([f'{path}: {note}'] if note else []):
            _note(args, line)
        check_excitation(d, path, to_fit=getattr(args, 'command', '') != 'compare')
        loaded.append((path, d))
    first = loaded[0][1]
    other = next(((p, d) for p, d in loaded if d.kind != first.kind), None)
    if other:
        path_of = {first.kind: loaded[0][0], other[1].kind: other[0]}
        raise UsageError(f'{path_of[StaticData.kind]} holds static curves but '
                         f'{path_of[DynamicData.kind]} is a dynamic record; '
                         'fit static and dynamic data separately')
    if not first.joinable:
        if len(loaded) > 1:
            raise UsageError(f'{loaded[1][0]}: give {first.noun} as one file (curve ids in a '
                             'curve column)')
        return loaded
    for path, d in loaded:
        apply_layout(d, getattr(args, 'layout', None), path)
    adopt_stated_unit(args, loaded, (spec or {}).get('position_unit'))
    convert_to_one_unit(args, loaded, (spec or {}).get('position_unit'))
    return loaded


def _column_renames(args: argparse.Namespace) -> Dict[str, str]:
    """Return the --column map {header: column name}; UsageError for a header given twice."""
    from .data import parse_column_map
    try:
        return parse_column_map(getattr(args, 'column', []))
    except ValueError as err:
        raise UsageError(f'--column: {err}') from None


def adopt_stated_unit(args: argparse.Namespace, loaded: List[Tuple[str, Any]],
                      model_unit: Optional[str] = None) -> None:
    """
    Give the records that name no position unit the unit of the model or of the others.

    Records are read with '' for a unit they do not name (`load_data` default_unit).
    Beside a model fitted in mm, or beside records that all name mm, such a record is one
    of the same rig whose logger left the unit out: it is read in mm, with a note. With no
    model and the others naming no unit or more than one, it is in rad, the default (mixed
    units are then an error).
    """
    others = {d.position_unit for _, d in loaded if d.position_unit}
    unit = model_unit or (others.pop() if len(others) == 1 else None)
    source = args.model if model_unit else 'the other records'
    for path, d in loaded:
        if not d.position_unit:
            d.position_unit = unit or 'rad'
            if unit and unit != 'rad':
                _note(args, f'note: {path} names no position unit; read in {unit}, the unit of '
                            f'{source} (give --position-unit if that is wrong)')


def convert_to_one_unit(args: argparse.Namespace, loaded: List[Tuple[str, Any]],
                        model_unit: Optional[str] = None) -> None:
    """
    Convert each record's position into the model's unit, or the first record's.

    A rig logged in mm one day and in um the next is still one rig: a record in another
    unit of the same quantity (`data.unit_factor`) has its position and setpoint scaled,
    with a note. Units of different quantities (mm and deg) stay as they are, for the
    model's or the join's one-line error.
    """
    from .data import in_unit, unit_factor
    target = model_unit or loaded[0][1].position_unit
    source = args.model if model_unit else loaded[0][0]
    for k, (path, d) in enumerate(loaded):
        converted = in_unit(d, target)
        if converted is None or converted is d:
            continue
        loaded[k] = (path, converted)
        _note(args, f'note: {path} has its position in {d.position_unit}: converted to '
                    f'{target}, the unit of {source} (1 {d.position_unit} = '
                    f'{unit_factor(d.position_unit, target):.6g} {target})')


def join_records(args: argparse.Namespace, loaded: List[Tuple[str, Any]],
                 **lead: Any) -> Any:
    """Return the checked records joined (`records.join`), the held-out ones last."""
    from .records import join
    if not loaded[0][1].joinable:
        return loaded[0][1]
    held = list(getattr(args, 'validate_on', None) or [])
    if not held and len(loaded) > 1 and getattr(args, 'command', '') != 'compare':
        held = [loaded[-1][0]]
    notes = []
    data = join(loaded, held_out=tuple(held), notes=notes, **lead)
    for line in notes:
        _note(args, line)
    return data


def data_lines(data: Any, role: Optional[str] = None) -> List[str]:
    """Return one line per record of `data`: 'NAME (role): dynamic record: ...' if joined."""
    return _KINDS[data.kind].lines(data, role)


def _record_lines(data: DynamicData, role: Optional[str] = None) -> List[str]:
    """Return one line per joined record of `data`: name, role (`role` if given), description."""
    from .data import describe
    from .records import segment_view
    if not data.segments:
        return [describe(data)]
    if len(data.segments) == 1:
        name, a, b = data.segments[0]
        return [f'{name}: {describe(segment_view(data, a, b))}']
    out = []
    for name, a, b in data.segments:
        held = data.split is not None and a >= data.split
        out.append(f'{name} ({role or ("validation" if held else "train")}): '
                   f'{describe(segment_view(data, a, b))}')
    return out


class _DynamicKind:
    """What the commands do with a dynamic record: per-record lines and scores, gaps cut."""

    lines = staticmethod(_record_lines)

    @staticmethod
    def records(data: DynamicData, prediction: np.ndarray, split: Optional[Split] = None,
                role: Optional[str] = None) -> List[Dict[str, Any]]:
        """
        Return the per-record scores of `prediction` (`engine.record_scores`).

        Compared records also get their `start_offset` (`records.start_offsets`).
        """
        from .engine import record_scores
        from .records import start_offsets
        rows = record_scores(data, prediction, split, role)
        if role == COMPARED:
            offsets = start_offsets(data, prediction)
            for r in rows:
                r['start_offset'] = offsets[r['data']]
        return rows

    @staticmethod
    def json(data: DynamicData, records: List[Dict[str, Any]]) -> Dict[str, Any]:
        """Return the records' scores and the rig settings for `compare --json`."""
        return {'records': records} | data.rig()


class _StaticKind:
    """What the commands do with static curves: one line, no records, all points scored."""

    @staticmethod
    def lines(data: StaticData, role: Optional[str] = None) -> List[str]:
        """Return the one line describing the curves (they have no roles)."""
        from .data import describe
        return [describe(data)]

    @staticmethod
    def records(data: StaticData, prediction: np.ndarray, split: Optional[Split] = None,
                role: Optional[str] = None) -> List[Dict[str, Any]]:
        """Return no per-record scores (the curves are one file)."""
        return []

    @staticmethod
    def json(data: StaticData, records: List[Dict[str, Any]]) -> Dict[str, Any]:
        """Return nothing to add to `compare --json`."""
        return {}


# the command-line handling of each data kind (like compare's _VIEWS: it needs workbench code)
_KINDS = {DynamicData.kind: _DynamicKind, StaticData.kind: _StaticKind}


def read_model_spec(path: str, catalog: Optional[Mapping[str, Any]]) -> Dict[str, Any]:
    """Return MODEL.yaml as a checked dict (effects known to the catalog; None: any name)."""
    from ..core.model_file import read_model
    return read_model(path, known_effects=catalog)


def read_fitted_spec(path: str, catalog: Optional[Mapping[str, Any]]) -> Dict[str, Any]:
    """Return `read_model_spec` of a fit's model file; refuse a file without a fitted model."""
    from ..core.model_file import is_fitted
    spec = read_model_spec(path, catalog)
    if not is_fitted(spec):
        raise UsageError(f'{path}: holds no fitted model (no "model" section); run '
                         f'{PROG} fit DATA --out FITTED.yaml first')
    return spec


def model_signals(fit: Any, data: Any) -> Dict[str, np.ndarray]:
    """Return the model wire temperatures [°C] to compare: the fit's, re-simulated or none."""
    if fit.signals:
        return fit.signals
    params = getattr(fit, 'params', None)
    if hasattr(params, 'hysteresis') and hasattr(data, 'duty_a'):
        from ..core.actuator import simulate
        tr = simulate(params, data.duty_a, data.duty_b, data.dt, ambient_c=data.ambient)
        return {'theta_a': tr.theta_a_c, 'theta_b': tr.theta_b_c}
    return {}


def json_safe(obj: Any) -> Any:
    """Return plain JSON data: numpy -> Python, non-finite floats -> None."""
    from ..core.model_file import to_plain
    obj = to_plain(obj)
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [json_safe(v) for v in obj]
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def print_json(obj: Any) -> None:
    """Print strict JSON (no NaN) to stdout."""
    print(json.dumps(json_safe(obj), indent=2, allow_nan=False))


def model_line(effects: Sequence[str], kind: str) -> str:
    """Return 'modified PI base + saturation, delay' ('... (the paper's model)' if none)."""
    if effects:
        return f'{kind} PI base + {", ".join(effects)}'
    return f'{kind} PI base' + (" (the paper's model)" if kind == 'modified' else '')


# ------------------------------------------------------------------------------ fit
def cmd_fit(args: argparse.Namespace) -> int:
    """Run `sma-model fit`: fit the base model plus effects; print scores; write FITTED.yaml."""
    from .compare import score_line
    from ..core.model_file import check_writable, write_model
    catalog = setup_effects(args)
    check_outputs_spare_data(args)
    if args.out:
        check_writable(args.out, args.force)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    add = args.add or []
    check_effect_names(add, catalog)
    effects = list(dict.fromkeys(spec['effects'] + add))
    kind = args.kind or spec.get('kind')
    loaded = load_checked_records(args, spec)
    progress = Progress('fit')
    try:
        data, fit, records = _fit_records(args, loaded, tuple(effects), kind, progress)
        led, lead = try_lead_in(args, loaded, fit, data, lambda **lead: _fit_records(
            args, loaded, tuple(effects), kind, progress, **lead))
        if led:
            data, fit, records = led
        mark_warm(records, lead)
        profile = _tau_profile(args, data, fit, progress) | _duty_levels(data, fit)
    finally:
        progress.close()
    if profile.get('tau_profile', {}).get('identified') is False:
        _note(args, f'note: {profile["tau_profile"]["note"]}')
    if profile.get('duty_levels', {}).get('one_level'):
        _note(args, f'note: {profile["duty_levels"]["note"]}')
    if 'sensor_zero' not in fit.effects and data.kind == DynamicData.kind:
        _note_apart_rests(args, loaded, data)
    if args.out:
        write_model(args.out, dict(fit.to_dict(), **profile), force=args.force)
    floor = _noise_floor(data)
    if args.json:
        print_json(dict(fit_json(fit, args.out, records), **profile, noise_floor_nrmse=floor))
    else:
        print(f'model: {model_line(fit.effects, fit.kind)} ({fit.n_parameters} parameters)')
        if fit.values:
            print('fitted: ' + ', '.join(f'{k} = {v:.4g}' for k, v in fit.shown_values().items()))
        unit = data.output_unit
        for r in records if len(records) > 1 else []:
            print(score_line(f'{r["data"]} ({r["role"]})', r['scores']['all'], unit, 0,
                             r['role'] != 'train'))
        print(score_line('train', fit.train, unit))
        print(score_line('validation', fit.validation, unit))
        noise = _noise(floor, data, {'train': fit.train, 'validation': fit.validation}, unit)
        if noise:
            print(noise)
    if args.out:
        _note(args, f'wrote {args.out}')
    return 0


def _noise_floor(data: Any) -> Optional[float]:
    """Return the NRMSE the measurement noise alone gives (`engine.noise_floor`; None: static)."""
    from .engine import noise_floor
    return noise_floor(data)


def _noise(floor: Optional[float], data: Any, scores: Dict[str, Optional[dict]],
           unit: str) -> Optional[str]:
    """
    Return the noise's score line (`remaining.noise_line`), None where `floor` is None.

    floor: `_noise_floor(data)`; scores: {part: scores dict or None}; a held-out part too
    narrow to score (`"informative": false`) is left out, as its score line leaves it
    unscored.
    """
    shown = ((p, scores.get(p)) for p in ('train', 'validation', 'all'))
    nrmse = {p: s.get('nrmse') for p, s in shown if s and s.get('informative', True)}
    return noise_line(floor, data.span(), nrmse, unit) if floor else None


def _tau_profile(args: argparse.Namespace, data: Any, fit: Any,
                 progress: Progress) -> Dict[str, Any]:
    """
    Return {'tau_profile': ...} for a dynamic fit ({} for curves).

    Two more fits with the thermal time constant held (`identifiability.tau_profile`).
    """
    from .identifiability import tau_profile
    if getattr(data, 'kind', None) != DynamicData.kind or 'tau_s' not in fit.values:
        return {}
    profile = tau_profile(data, fit, jobs=args.jobs, progress=progress)
    return {'tau_profile': profile.to_json()}


def _duty_levels(data: Any, fit: Any) -> Dict[str, Any]:
    """Return {'duty_levels': ...} of a dynamic fit's training samples ({} for curves)."""
    from .levels import duty_levels
    dynamic = getattr(data, 'kind', None) == DynamicData.kind
    levels = duty_levels(data, fit.split) if dynamic else None
    return {'duty_levels': levels.to_json()} if levels else {}


def _fit_records(args: argparse.Namespace, loaded: List[Tuple[str, Any]], effects: tuple,
                 kind: Optional[str], progress: Progress, **lead: Any) -> tuple:
    """
    Fit the records; return (data, fit, per-record rows).

    Several records without --validate-on: each left out in turn (`crossval`); else one
    split. lead: `records.join`'s lead_in and tau_s (`leadins.lead_ins`); the records
    are described (notes) only on the first fit, the one without.
    """
    from .crossval import all_records, cross_validate, LEFT_OUT
    from .engine import fit_model
    if len(loaded) > 1 and not args.validate_on:
        if not lead:
            notes = []
            lines = _record_lines(all_records(loaded, notes), LEFT_OUT)
            for line in notes + lines:
                _note(args, line)
            _note(args, 'validation: each record predicted by the model fitted on the others; '
                  f'the model written is fitted on all {len(loaded)} (--validate-on to hold '
                  'records out)')
        return cross_validate(loaded, effects, kind, jobs=args.jobs, progress=progress,
                              **lead)
    data = join_records(args, loaded, **lead)
    for line in [] if lead else data_lines(data):
        _note(args, line)
    fit = fit_model(data, effects=effects, kind=kind, progress=progress)
    return data, fit, per_record(fit, data)


def per_record(fit: Any, data: Any) -> List[Dict[str, Any]]:
    """Return the per-record scores of a dynamic fit ([] for static curves)."""
    return _KINDS[data.kind].records(data, fit.prediction, fit.split)


def fit_json(fit: Any, out: Optional[str],
             records: Sequence[Dict[str, Any]] = ()) -> Dict[str, Any]:
    """Return the `fit --json` document."""
    val = fit.validation or {}
    doc = {'effects': list(fit.effects), 'kind': fit.kind,
           'train_nrmse': fit.train['nrmse'], 'validation_nrmse': val.get('nrmse'),
           'parameters': fit.shown_values(), 'n_parameters': fit.n_parameters,
           'train': fit.train, 'validation': fit.validation,
           'out': str(out) if out else None}
    if records:
        doc['records'] = list(records)
    doc.update(fit.rig)
    return doc


# ------------------------------------------------------------------------------ compare
def cmd_compare(args: argparse.Namespace) -> int:
    """Run `sma-model compare`: score a fitted model on DATA, break the error down, test it."""
    from .compare import compare, score_line, summary_lines
    from .engine import model_travel
    from .leadins import lead_ins
    from ..core.model_file import is_static_model
    from .report import check_report_dir
    catalog = setup_effects(args)
    check_outputs_spare_data(args)
    if args.report:
        check_report_dir(args.report, args.force)
    spec = read_fitted_spec(args.model, catalog)
    loaded = load_checked_records(args, spec)
    names = ' '.join(all_data(args))
    first = loaded[0][1]
    fitted_on = StaticData if is_static_model(spec) else DynamicData
    if fitted_on.kind != first.kind:
        raise UsageError(f'{args.model} was fitted on {fitted_on.noun} but '
                         f'{names} is {first.noun}')
    check_rig(spec, first, args.model)
    lead = lead_ins(_fitted(args, spec), loaded) if first.joinable else {}
    led_lines = note_lead_in(args, lead, loaded)
    data = join_records(args, loaded, **lead)
    fit = _fitted(args, spec, data)
    profile = spec.get('tau_profile')
    if isinstance(profile, dict) and profile.get('identified') is False:
        _note(args, f'note: {args.model}: {profile.get("note") or "τ was not identified"}')
    _note_other_levels(args, spec.get('duty_levels'), data)
    kind = _KINDS[data.kind]
    records = kind.records(data, fit.prediction, role=COMPARED)
    mark_warm(records, lead)
    mark_untared(records, fit.untared)
    _note_start_offsets(args, data, records)
    result = compare(data, fit.prediction, model_signals(fit, data),
                     split=Split(0) if len(records) > 1 else None)
    travel = model_travel(fit.params, data)
    if travel:
        _note_quiet_records(args, data, travel)
    title = f'{PROG} compare: {names} with {args.model}'
    lines = data_lines(data, COMPARED)
    floor = _noise_floor(data)
    noise = _noise(floor, data, result.scores, result.unit)
    if args.report:
        _write_report(args, result, title,
                      '; '.join(lines + led_lines + ([noise.strip()] if noise else [])), spec)
    if args.json:
        doc = {'data': str(args.data[0]) if len(all_data(args)) == 1 else all_data(args),
               'model': {'effects': spec['effects'], 'kind': spec.get('kind')}}
        doc |= result.to_json()
        doc |= kind.json(data, records)
        if travel:
            doc['model_travel'] = travel
        doc['noise_floor_nrmse'] = floor
        print_json(doc)
    else:
        print('\n'.join(lines))
        print(f'model: {model_line(spec["effects"], spec.get("kind") or "modified")}')
        for r in records if len(records) > 1 else []:
            print(score_line(r['data'], r['scores']['all'], result.unit, 0))
        print('\n'.join(summary_lines(result, noise=noise)))
    return 0


def _note_other_levels(args: argparse.Namespace, fitted: Any, data: Any) -> None:
    """Note a compared record that heats at other duty levels than the one-level fit."""
    from .levels import heated_duties, ONE_LEVEL_SHARE, share_at
    if not (isinstance(fitted, dict) and fitted.get('one_level')
            and data.kind == DynamicData.kind):
        return
    try:
        level, tol = float(fitted['level']), float(fitted['tolerance'])
    except (KeyError, TypeError, ValueError):
        return
    heated = heated_duties(data)
    share = share_at(heated, level, tol)
    if heated.size and share < ONE_LEVEL_SHARE:
        _note(args, f'note: {args.model} was fitted at one duty level ({level:.3g} ± {tol:.2g}); '
              f'{100 * (1 - share):.0f} % of the heated time here is at other duty levels, '
              "where the model's heating law is not identified")


def _fitted(args: argparse.Namespace, spec: Mapping[str, Any], data: Any = None) -> Any:
    """Return the model file's fit (`engine.load_fit`), scored on `data` if given."""
    from .engine import load_fit
    try:
        return load_fit(spec, data=data)
    except (KeyError, TypeError, ValueError) as err:
        what = f'missing {err}' if isinstance(err, KeyError) else str(err)
        raise UsageError(f'{args.model}: cannot use the fitted model ({what})') from None


def try_lead_in(args: argparse.Namespace, loaded: List[Tuple[str, Any]], fit: Any, data: Any,
                refit: Callable[..., tuple]) -> Tuple[Optional[tuple], Dict[str, Any]]:
    """Return `leadins.refit_led` of the first `fit`, noting the lead-ins it keeps."""
    from .leadins import refit_led
    led, lead = refit_led(fit, data, loaded, refit)
    note_lead_in(args, lead, loaded)
    return led, lead


def lead_in_lines(lead: Dict[str, Any], loaded: List[Tuple[str, Any]]) -> List[str]:
    """Return a line for each record led in (warm or cooling), and for a longer rest."""
    from .records import REST_GAP_S, REST_TAUS, rest_gap_s
    lines = [f'{name} {_lead_in_words(d, lead["lead_in"][name], lead)}'
             for name, d in loaded if name in lead.get('lead_in', {})]
    if 'tau_s' in lead:
        tau = lead['tau_s']
        lines.append(f'τ = {tau:.3g} s: the records are joined with {rest_gap_s(tau):.0f} s '
                     f'of rest ({REST_TAUS:g} τ, not {REST_GAP_S:.0f} s), so each starts cold')
    return lines


def note_lead_in(args: argparse.Namespace, lead: Dict[str, Any],
                 loaded: List[Tuple[str, Any]]) -> List[str]:
    """Note each of `lead_in_lines`; return them (an HTML report's description takes them)."""
    lines = lead_in_lines(lead, loaded)
    for line in lines:
        _note(args, f'note: {line}')
    return lines


def _lead_in_words(d: Any, lead_in: tuple, lead: Dict[str, Any]) -> str:
    """Return how record `d` starts and is simulated, by its (duty_a, duty_b, first_s)."""
    from .records import rest_gap_s, starts_heated
    a, b, first_s = lead_in
    if starts_heated(d):
        how = ('from the steady state of those duties' if first_s >= rest_gap_s(
            lead.get('tau_s')) - d.dt else f'with those duties on for {first_s:.3g} s before it')
        return (f'starts with the wires warm (duty_a {d.duty_a[0]:.3g}, duty_b '
                f'{d.duty_b[0]:.3g} on at its first sample): simulated {how}, not from rest')
    return ('starts at zero duty with a wire still cooling (it moves before any duty): '
            f'simulated from duty_a {a:.3g}, duty_b {b:.3g} held, then {first_s:.3g} s at '
            'zero duty, not from rest')


def mark_warm(records: List[Dict[str, Any]], lead: Dict[str, Any]) -> None:
    """
    Give each per-record row `warm_start`: whether it was simulated from warm.

    A record led in (`leadins.started`) also gets `lead_in`: the duties held before its
    first duties and how long those had been on when it began [s].
    """
    led = lead.get('lead_in', {})
    for r in records:
        r['warm_start'] = r['data'] in led
        if r['data'] in led:
            a, b, first_s = led[r['data']]
            r['lead_in'] = {'duty_a': a, 'duty_b': b, 'first_duties_s': round(first_s, 3)}


def _note_apart_rests(args: argparse.Namespace, loaded: List[Tuple[str, Any]],
                      data: DynamicData) -> None:
    """
    Note records of a fit whose start rests lie further apart than a rest scatters.

    Apart by more than `records.UNTARED_SHARE` of the measured range of the joined `data`,
    the sensor was most likely not tared between them, which `sensor_zero` takes up.
    """
    from .records import start_rests, UNTARED_SHARE
    rests = start_rests(loaded)
    if len(rests) < 2:
        return
    span, unit = data.span(), data.output_unit
    low, high = min(rests, key=rests.get), max(rests, key=rests.get)
    if rests[high] - rests[low] > UNTARED_SHARE * span:
        _note(args, f'note: the records start at rests {rests[high] - rests[low]:.4g} {unit} '
              f'apart ({high} at {rests[high]:.4g} {unit}, {low} at {rests[low]:.4g} {unit}; '
              f'{100 * UNTARED_SHARE:.0f} % of the range is {UNTARED_SHARE * span:.3g} {unit}): '
              'an untared sensor? fit with --add sensor_zero to refer each record to its own '
              'start rest, or see what diagnose names')


def _note_quiet_records(args: argparse.Namespace, data: Any, travel: float) -> None:
    """
    Note compared records that move less than `engine.MIN_COVERAGE` of the model's travel.

    Their NRMSE is over their own small range: an error that is small against the stroke
    can read as hundreds of percent there, so the RMSE is the figure to read.
    """
    from .engine import MIN_COVERAGE
    moved = data.span()
    if moved < MIN_COVERAGE * travel:
        unit = data.output_unit
        _note(args, f'note: the compared records move {moved:.4g} {unit}, '
                    f"{100 * moved / travel:.0f} % of the model's travel ({travel:.4g} {unit}): "
                    'their NRMSE, over that range, says little; read the RMSE')


def mark_untared(records: List[Dict[str, Any]], untared: Mapping[str, float]) -> None:
    """
    Mark the compared records `engine.load_fit` predicted from their own start rest.

    Their `start_offset` stays the offset from the model's rest, and `untared` is True.
    """
    for r in records:
        if r['data'] in untared:
            r['start_offset'] = float(untared[r['data']])
            r['untared'] = True


def _note_start_offsets(args: argparse.Namespace, data: Any,
                        records: List[Dict[str, Any]]) -> None:
    """
    Note each compared record predicted from its own start rest (`mark_untared`).

    Those are the records `records.untared_offsets` finds read by an untared sensor (one
    led in warm or cooling does not start at rest).
    """
    unit = data.output_unit
    for r in records:
        if r.get('untared'):
            _note(args, f'note: {r["data"]} starts at rest {r["start_offset"]:+.4g} {unit} from '
                  "the model's rest (an untared sensor?): predicted from its own start rest "
                  '(fit with --add sensor_zero to refer every record to its own start rest)')


def check_rig(spec: Mapping[str, Any], data: Any, source: str) -> None:
    """Raise UsageError if the model file's position unit or layout differ from the data's."""
    for key, value in data.rig().items():
        want = spec.get(key)
        if want is not None and want != value:
            raise UsageError(f'{source}: fitted with {key} {want}, but the data has {value} '
                             f'(give --{key.replace("_", "-")} {want} if that is wrong)')


def _write_report(args: argparse.Namespace, comparison: Any, title: str, data_line: str,
                  model: Mapping[str, Any]) -> None:
    """Write the HTML report of --report and name its index on the note stream."""
    from .report import write_report
    index = write_report(args.report, comparison, title, data_line=data_line, model=model,
                         force=args.force)
    _note(args, f'report: {index}')


# ------------------------------------------------------------------------------ diagnose
def cmd_diagnose(args: argparse.Namespace) -> int:
    """Run `sma-model diagnose`: refit with each candidate effect, rank by held-out improvement."""
    from .engine import diagnose_rounds, fit_model
    from .report import check_report_dir
    catalog = setup_effects(args)
    check_outputs_spare_data(args)
    if args.report:
        check_report_dir(args.report, args.force)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    if args.candidates:
        check_effect_names(args.candidates, catalog, '--candidates')
    kind = args.kind or spec.get('kind')
    loaded = load_checked_records(args, spec)
    data = join_records(args, loaded)
    for line in data_lines(data):
        _note(args, line)
    progress = Progress('base fit')
    try:
        base = fit_model(data, effects=tuple(spec['effects']), kind=kind, progress=progress)

        def refit(**lead: Any) -> tuple:
            led = join_records(args, loaded, **lead)
            return led, fit_model(led, effects=tuple(spec['effects']), kind=kind,
                                  progress=progress)
        led, lead = try_lead_in(args, loaded, base, data, refit)
        data, base = led or (data, base)
        progress.stage = 'diagnose'
        diags, rounds, base = diagnose_rounds(data, base, args.rounds, candidates=args.candidates,
                                              progress=progress, jobs=args.jobs)
        profile = _tau_profile(args, data, diags[0].baseline, progress)
        profile |= _duty_levels(data, diags[0].baseline)
    finally:
        progress.close()
    doc = _diagnosis_doc(args, diags, rounds, base, profile)
    if args.report:
        _write_diagnose_report(args, data, diags[0], doc, lead, loaded)
    if args.json:
        print_json(doc)
    else:
        _print_diagnosis(args, doc, diags[0], profile, catalog)
    return 0


def _diagnosis_doc(args: argparse.Namespace, diags: list, rounds: list, base: Any,
                   profile: dict) -> dict:
    """Return the JSON of a diagnosis: the first round's keys, then the rounds and final."""
    doc = diags[0].to_json()
    doc['baseline'].update(profile)
    if args.rounds > 1:
        doc['rounds'] = rounds
        doc['rounds_limit'] = args.rounds
        doc['final'] = {'effects': list(base.effects),
                        'validation_nrmse': base.validation['nrmse'],
                        'train_nrmse': base.train['nrmse']}
        if diags[-1].refitted and diags[-1].missing_effect is None:
            doc['final']['refitted'] = diags[-1].refitted
        if diags[-1].training_lead:
            doc['final']['training_lead'] = diags[-1].training_lead
    return doc


def _write_diagnose_report(args: argparse.Namespace, data: Any, first: Any, doc: dict,
                           lead: Any, loaded: list) -> None:
    """Write the HTML report: the base model, the named effect's fit and the rounds' plot."""
    from .report import save_rounds_plot, write_diagnosis_report
    index = write_diagnosis_report(args.report, data, first,
                                   f'{PROG} diagnose: {" ".join(all_data(args))}',
                                   '; '.join(data_lines(data) + lead_in_lines(lead, loaded)),
                                   force=args.force, doc=doc)
    _note(args, f'report: {index}')
    if args.rounds > 1 and doc.get('rounds'):
        _note(args, f'rounds: {save_rounds_plot(args.report, doc)}')


def _print_diagnosis(args: argparse.Namespace, doc: dict, first: Any, profile: dict,
                     catalog: Mapping[str, Any]) -> None:
    """Print the diagnosis as text, with a note for each reason not to trust its ranking."""
    print('\n'.join(diagnosis_lines(doc, first.baseline.kind)))
    val = first.baseline.validation or {}
    if val.get('informative') is False:
        print(f'note: the held-out part covers {100 * val["coverage"]:.0f} % of the '
              'measured range, too little to rank effects reliably (hold out another '
              'record: give two or more records, or --validate-on)')
    if profile.get('tau_profile', {}).get('identified') is False:
        print(f'note: {profile["tau_profile"]["note"]}; a held-out error from a wrong τ '
              'is not a missing effect')
    if profile.get('duty_levels', {}).get('one_level'):
        laws = ', '.join(n for n, e in catalog.items() if e.heating_law)
        print(f'note: {profile["duty_levels"]["note"]}; so no effect on the heating law '
              f'({laws}) is named here')
    if args.rounds > 1:
        print('\n'.join(rounds_lines(doc, args.rounds)))


def diagnosis_lines(doc: Mapping[str, Any], kind: str) -> List[str]:
    """Return the text table of a diagnosis document, best candidate first."""
    base = doc['baseline']
    floor = base.get('noise_floor_nrmse')
    lines = [f'baseline: {model_line(base["effects"], kind)}, validation NRMSE '
             f'{_pct(base["validation_nrmse"])}'
             + (f' (the measurement noise alone: {_pct(floor)})' if floor else '')]
    if 'refitted' in base:
        lines.append(f'  {base["refitted"]}')
    lines.append(f'{"effect":<20} {"val. NRMSE":>10} {"improvement":>11}  significant')
    for c in doc['candidates']:
        imp = 'n/a' if c['improvement'] is None else f'{100 * c["improvement"]:+.0f} %'
        lines.append(f'{c["effect"]:<20} {_pct(c["validation_nrmse"]):>10} {imp:>11}  '
                     f'{"yes" if c["significant"] else "no"}')
    missing = doc['missing_effect']
    unresolved = [] if missing else [c for c in doc['candidates'] if c.get('not_resolved')]
    why = ('the candidates that cut the held-out error are not resolved by these records'
           if unresolved else 'no candidate cuts the held-out error clearly')
    lines.append(f'missing effect: {missing}' if missing else f'missing effect: none ({why})')
    lines += [f'  {c["effect"]} cuts it by {100 * c["improvement"]:.0f} %, not resolved: '
              f'{c["not_resolved"]}' for c in unresolved]
    lines += [f'  {c["effect"]} passed every check, but {c["rival"]} cuts the held-out error '
              'more: not named' for c in doc['candidates'] if c.get('rival') and not missing]
    if missing:
        c = next(c for c in doc['candidates'] if c['effect'] == missing)
        lines.append(f'  {c["explanation"]}')
    lines += ['  ' + line for line in remaining_lines(doc)]
    if missing:
        lines.append(f'  next: {PROG} fit DATA --add {missing} ... --out FITTED.yaml')
    return lines


# ------------------------------------------------------------------------------ batch
def cmd_batch(args: argparse.Namespace) -> int:
    """Run `sma-model batch`: fit, compare and diagnose every record on a Dask cluster."""
    from .batch import (BatchOptions, BatchProgress, find_records, run_batch, start_client,
                        worker_plugins)
    from .fleet import write_index, write_table
    catalog = setup_effects(args)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    if args.candidates:
        check_effect_names(args.candidates, catalog, '--candidates')
    _column_renames(args)
    paths = find_records(args.data)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f'--out {out}: exists and is not a directory')
    if any(out.resolve() == p for p in paths):
        raise UsageError(f'--out {out} is one of the records; choose another path')
    out.mkdir(parents=True, exist_ok=True)
    from ..core.model_file import is_fitted
    options = BatchOptions(effects=tuple(spec['effects']), kind=args.kind or spec.get('kind'),
                           candidates=tuple(args.candidates) if args.candidates else None,
                           rounds=args.rounds, rate_hz=args.rate, max_rate_hz=args.max_rate,
                           reports=not args.no_reports,
                           reference=json_safe(spec) if is_fitted(spec) else None,
                           position_unit=args.position_unit,
                           default_unit=spec.get('position_unit') or 'rad',
                           layout=args.layout, columns=tuple(args.column),
                           keep_glitches=args.keep_glitches,
                           plugins=worker_plugins(args.plugin))
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


def _close_client(client: Any) -> None:
    """Close the client and, if it started one, its local cluster."""
    cluster = client.cluster
    client.close()
    if cluster is not None:
        cluster.close()


# ------------------------------------------------------------------------------ effects
def cmd_effects(args: argparse.Namespace) -> int:
    """Run `sma-model effects`: list the catalog (plug-ins too): parameters, signature, physics."""
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


# ------------------------------------------------------------------------------ excite
def cmd_excite(args: argparse.Namespace) -> int:
    """Run `sma-model excite`: write an identification excitation in the rig's time scale."""
    from ..core.excitation import rig_excitation
    from ..core.model_file import check_writable
    from .excite import design_lines, write_bag, write_csv
    tau_s, (full_a, full_b), layout = _excite_design(args)
    out = Path(args.out)
    csv_out = out.suffix.lower() == '.csv'
    check_writable(out, args.force, directory=not csv_out)
    dt_s = 1.0 / args.rate
    duty_a, duty_b = rig_excitation(args.duration, dt_s, tau_s, full_a, layout, args.seed,
                                    duty_full_b=full_b)
    lines = design_lines(args.duration, args.rate, tau_s, full_a, layout, args.seed,
                         duty_full_b=full_b)
    if csv_out:
        write_csv(out, duty_a, duty_b, dt_s, lines)
    else:
        write_bag(out, duty_a, duty_b, dt_s, overwrite=args.force)
    for line in lines[:2]:
        print(line)
    print(f'wrote {out}')
    return 0


def _excite_design(args: argparse.Namespace) -> Tuple[float, Tuple[float, float], str]:
    """Return excite's (tau_s, (duty_full_a, duty_full_b), layout): the flags, else --model's."""
    from ..core.identification import MAX_TAU_S
    from ..core.model_file import is_static_model
    from .excite import MAX_DURATION_S, model_design
    tau_s, layout = args.tau_s, args.layout
    duty_full = None if args.duty_full is None else (args.duty_full, args.duty_full)
    if args.model:
        spec = read_fitted_spec(args.model, None)   # effect names do not matter here
        if is_static_model(spec):
            raise UsageError(f'{args.model}: a static (curve) fit has no thermal time '
                             'constant; give --tau-s and --duty-full')
        design = model_design(spec, _fitted(args, spec).params)
        for note in design[3]:
            print(f'note: {note}')
        tau_s = design[0] if tau_s is None else tau_s
        duty_full = design[1] if duty_full is None else duty_full
        layout = design[2] if layout is None else layout
    elif tau_s is None or duty_full is None:
        raise UsageError('give --tau-s and --duty-full, or --model FITTED.yaml')
    if not tau_s <= MAX_TAU_S:
        raise UsageError(f'tau {tau_s:g} s is over {MAX_TAU_S:g} s, the largest '
                         'time constant the fit takes')
    if not max(duty_full) <= 1:
        raise UsageError(f'--duty-full {max(duty_full):g} is over 1 (the duty is 0-1)')
    if not 10 * tau_s <= args.duration <= MAX_DURATION_S:
        raise UsageError(f'--duration {args.duration:g} s is outside 10 x tau '
                         f'({10 * tau_s:g} s) to {MAX_DURATION_S:g} s')
    return tau_s, duty_full, layout or 'antagonistic'


# ------------------------------------------------------------------------------ parser
def build_parser() -> argparse.ArgumentParser:
    """Return the argparse parser of `sma-model` (one-line errors, exit code 2)."""
    common = _common_options()
    parser = OneLineParser(prog=PROG, description='Compare the SMA actuator model with '
                           'measurements, find the missing physical effect, add it.')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND',
                                parser_class=OneLineParser)
    for add_command in (_add_fit, _add_compare, _add_diagnose, _add_batch, _add_effects,
                        _add_excite):
        add_command(sub, common)
    return parser


def _common_options() -> argparse.ArgumentParser:
    """Return the parent parser of the options that fit, compare and diagnose share."""
    common = argparse.ArgumentParser(add_help=False, parents=[_reading_options()])
    common.add_argument('data', metavar='DATA', nargs='+',
                        help='CSVs (dynamic or static curves) or MCAP bags (file or '
                        'directory); several dynamic records of one rig are fitted together')
    common.add_argument('--validate-on', nargs='+', action='extend', metavar='DATA',
                        help='hold these records out for validation (default: fit: each of '
                        'several records left out in turn, the model written fitted on all; '
                        'diagnose: the last record; one record: the last 30 %% of time)')
    common.add_argument('--plugin', action='append', metavar='FILE.py|MODULE',
                        help='load user effects from a Python file or module (repeatable)')
    common.add_argument('--json', action='store_true', help='print the result as JSON')
    common.add_argument('--force', action='store_true', help='overwrite existing output files')
    return common


def _reading_options() -> argparse.ArgumentParser:
    """Return the parent parser of how records are read (fit, compare, diagnose, batch)."""
    reading = argparse.ArgumentParser(add_help=False)
    reading.add_argument('--layout', choices=('single', 'antagonistic'),
                         help='rig layout (default: from the data; single = one wire against '
                         'a bias spring, duty_b absent or always 0)')
    reading.add_argument('--position-unit', type=_position_unit, metavar='UNIT',
                         help='unit of position and setpoint (default: from the header, e.g. '
                         'position[mm], or a "# ... position in mm" comment; else rad)')
    reading.add_argument('--column', action='append', type=_column_pair, default=[],
                         metavar='NAME=HEADER',
                         help="read a CSV's column HEADER as NAME, e.g. position[mm]=pot_mm, "
                         'time[ns]=__time (repeatable; NAME: time, duty_a, duty_b, duty, '
                         'position, ambient_temperature, setpoint)')
    reading.add_argument('--rate', type=_positive_float, metavar='HZ',
                         help='resampling rate for MCAP bags [Hz] (default: joint-state rate)')
    reading.add_argument('--max-rate', type=_positive_float, metavar='HZ',
                         default=MAX_FIT_RATE_HZ, help=MAX_RATE_HELP)
    reading.add_argument('--keep-glitches', action='store_true',
                         help='read positions that jump away and back within 3 samples '
                         '(30 ms above 100 Hz) as measured (default: bridged as sensor '
                         'glitches, not scored)')
    return reading


def _add_fit(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `fit`: fit a model to DATA, print scores, write it with --out."""
    fit = sub.add_parser('fit', parents=[common], help='fit a model, print scores',
                         description='Fit the base model plus effects to DATA.')
    fit.add_argument('--model', metavar='MODEL.yaml', help='effects (and kind) to start from')
    fit.add_argument('--add', nargs='+', action='extend', metavar='EFFECT',
                     help='effects to add to the model')
    fit.add_argument('--kind', choices=('classical', 'modified'),
                     help='hysteresis base (default: from MODEL.yaml, else modified)')
    fit.add_argument('--out', metavar='FITTED.yaml', help='write the fitted model')
    fit.add_argument('--jobs', type=_non_negative_int, default=0, metavar='N',
                     help='processes for the fits of several records, each left out in turn '
                     '(default 0: every core)')
    fit.set_defaults(func=cmd_fit)


def _add_compare(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `compare`: score a fitted model on DATA and say where it fails."""
    cmp_ = sub.add_parser('compare', parents=[common], help='where a fitted model fails',
                          description='Score a fitted model on DATA, break the error down '
                          'by regime and test the residual.')
    cmp_.add_argument('--model', required=True, metavar='FITTED.yaml',
                      help='fitted model (from fit --out)')
    cmp_.add_argument('--report', metavar='DIR', help='write an HTML report with figures')
    cmp_.set_defaults(func=cmd_compare)


def _add_diagnose(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `diagnose`: rank the catalog effects by held-out error reduction."""
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
    dia.add_argument('--rounds', type=_positive_int, default=1, metavar='N',
                     help='add the missing effect, refit and diagnose again, up to N rounds, '
                     'stopping when nothing is significant (default 1)')
    dia.set_defaults(func=cmd_diagnose)


def _add_batch(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `batch`: fit, compare and diagnose many records on Dask."""
    bat = sub.add_parser('batch', parents=[_reading_options()],
                         help='fit, compare and diagnose many records (Dask)',
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
    bat.add_argument('--no-reports', action='store_true', help='skip the per-record reports')
    bat.add_argument('--force', action='store_true', help='recompute finished records')
    bat.add_argument('--json', action='store_true', help='print a JSON summary')
    bat.add_argument('--plugin', action='append', metavar='FILE.py|MODULE',
                     help='load user effects from a Python file or module (repeatable); '
                     'every worker loads them, so a file must be at that path on each')
    bat.set_defaults(func=cmd_batch)


def _add_effects(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `effects`: list the effect catalog."""
    eff = sub.add_parser('effects', help='list the effect catalog (with plug-ins)',
                         description='List every effect: parameters, physics, signature.')
    eff.add_argument('--plugin', action='append', metavar='FILE.py|MODULE',
                     help='load user effects from a Python file or module (repeatable)')
    eff.add_argument('--json', action='store_true', help='print the catalog as JSON')
    eff.set_defaults(func=cmd_effects)


def _add_excite(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `excite`: write an identification excitation for a rig."""
    exc = sub.add_parser('excite', help='write an identification excitation for a rig',
                         description='Write the duty sequence of an identification record '
                         "in the rig's own time: holds of 0.75-2.5 tau at six duties from "
                         '0.5 to 1 x --duty-full. OUT.csv: time,duty_a,duty_b for your own '
                         'logger; any other OUT: a bag of /sma/duty commands for `replay`.')
    exc.add_argument('--model', metavar='FITTED.yaml',
                     help="take tau, the full-stroke duty and the layout from a fit's model "
                     'file (the flags below override each)')
    exc.add_argument('--tau-s', type=_positive_number, metavar='S',
                     help='thermal time constant of the wire [s] (the fitted tau_s)')
    exc.add_argument('--duty-full', type=_positive_number, metavar='D',
                     help='the duty that holds a wire at its full stroke (0-1)')
    exc.add_argument('--layout', choices=('single', 'antagonistic'),
                     help='single: one wire against a bias spring, duty_b 0 (default: '
                     "--model's, else antagonistic: one wire of the pair heated at a time)")
    exc.add_argument('--duration', type=_positive_number, default=480.0, metavar='S',
                     help='length of the record [s] (default 480: 8 minutes)')
    exc.add_argument('--rate', type=_positive_float, default=40.0, metavar='HZ',
                     help="duty command rate [Hz] (default 40, the controller's)")
    exc.add_argument('--seed', type=_non_negative_int, default=0, metavar='N',
                     help='random seed of the sequence (default 0)')
    exc.add_argument('--out', required=True, metavar='OUT.csv|BAG',
                     help='CSV file, or bag directory for `replay`')
    exc.add_argument('--force', action='store_true', help='overwrite OUT')
    exc.set_defaults(func=cmd_excite)


def _column_pair(text: str) -> str:
    """Check one ``NAME=HEADER`` of --column (argparse type)."""
    from .data import parse_column_map
    try:
        parse_column_map([text])
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return text


def _position_unit(text: str) -> str:
    """Return the canonical spelling of a position unit (argparse type)."""
    from .data import parse_unit
    try:
        return parse_unit(text, '--position-unit')
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err).partition(': ')[2]) from None


def _positive_float(text: str) -> float:
    """Parse a positive rate [Hz] within the accepted range (argparse type)."""
    from .limits import MAX_RATE_HZ, MIN_RATE_HZ
    value = _positive_number(text)
    if not MIN_RATE_HZ <= value <= MAX_RATE_HZ:
        raise argparse.ArgumentTypeError(f'{text} Hz is outside {MIN_RATE_HZ:g} to '
                                         f'{MAX_RATE_HZ:g} Hz')
    return value


def _positive_number(text: str) -> float:
    """Parse a positive finite number (a time [s], a duty; argparse type)."""
    from .limits import parse_number
    try:
        value = parse_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text[:40]!r} is not a number') from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f'{text!r} is not a positive number')
    return value


def _positive_int(text: str) -> int:
    """Parse an integer >= 1 (argparse type)."""
    value = _non_negative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f'{text!r} is not a positive integer')
    return value


def _non_negative_int(text: str) -> int:
    """Parse an integer >= 0 (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not an integer') from None
    if value < 0:
        raise argparse.ArgumentTypeError(f'{text!r} is negative')
    return value


def error_text(err: BaseException) -> str:
    """Return one line for an input error (OSError: file and reason)."""
    if isinstance(err, OSError) and err.strerror:
        text = f'{err.filename}: {err.strerror}' if err.filename else err.strerror
    else:
        text = str(err) or type(err).__name__
    return ' '.join(text.split())


def main(argv: Optional[Sequence[str]] = None) -> int:
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
