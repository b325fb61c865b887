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
The steps several `sma-model` commands share: reading and checking DATA, notes, JSON.

Records are loaded, put in one position unit and joined here; the model file is read and
checked; a lead-in (a record begun warm or cooling) is noted; progress and notes go to
stderr, or to stdout where it holds no JSON.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys
import time
from typing import Any, Callable, Dict, IO, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..remaining import noise_line, PROG
from ...core.datakinds import DynamicData, Split, StaticData

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
# the role of each record `compare` scores: neither trained on nor held out by it
COMPARED = 'compared'


class UsageError(ValueError):
    """Bad command-line input (reported as one line, exit code 2)."""


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


def note(args: argparse.Namespace, text: str) -> None:
    """Print a human-readable line: stdout normally, stderr with --json (stdout holds the JSON)."""
    print(text, file=sys.stderr if args.json else sys.stdout)


def setup_effects(args: argparse.Namespace) -> Dict[str, Any]:
    """Load entry-point and --plugin effects; return the catalog (name -> effect)."""
    from .. import plugins
    from ..effects import CATALOG
    plugins.load_entry_points()
    plugins.load_plugins(args.plugin or [])
    return CATALOG


def prepare_outputs(args: argparse.Namespace) -> Dict[str, Any]:
    """
    Return the effect catalog (`setup_effects`) once the outputs are checked, none written.

    --out and --report must not be DATA; an existing file or report is kept without --force.
    """
    from ..report import check_report_dir
    from ...core.model_file import check_writable
    catalog = setup_effects(args)
    check_outputs_spare_data(args)
    if getattr(args, 'out', None):
        check_writable(args.out, args.force)
    if getattr(args, 'report', None):
        check_report_dir(args.report, args.force)
    return catalog


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
    from ..data import apply_layout, check_excitation, load_data
    from ..records import at_fit_rate
    paths = all_data(args)
    seen = {}
    for path in paths:
        key = Path(path).resolve()
        if key in seen:
            raise UsageError(f'{path}: the same record as {seen[key]}; give each record once')
        seen[key] = path
    unit = getattr(args, 'position_unit', None)
    renames = column_renames(args)
    loaded = []
    for path in paths:
        notes = []
        d, rate_note = at_fit_rate(load_data(path, rate_hz=args.rate, position_unit=unit,
                                             notes=notes, default_unit='', renames=renames,
                                             keep_glitches=args.keep_glitches), args.max_rate)
        for line in notes + ([f'{path}: {rate_note}'] if rate_note else []):
            note(args, line)
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


def column_renames(args: argparse.Namespace) -> Dict[str, str]:
    """Return the --column map {header: column name}; UsageError for a header given twice."""
    from ..data import parse_column_map
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
                note(args, f'note: {path} names no position unit; read in {unit}, the unit of '
                           f'{source} (give --position-unit if that is wrong)')


def convert_to_one_unit(args: argparse.Namespace, loaded: List[Tuple[str, Any]],
                        model_unit: Optional[str] = None) -> None:
    """
    Convert each record's position into the model's unit, or the first record's.

    A rig logged in mm one day and in um the next is still one rig: a record in another
    unit of the same quantity (`units.unit_factor`) has its position and setpoint scaled,
    with a note. Units of different quantities (mm and deg) stay as they are, for the
    model's or the join's one-line error.
    """
    from ..units import in_unit, unit_factor
    target = model_unit or loaded[0][1].position_unit
    source = args.model if model_unit else loaded[0][0]
    for k, (path, d) in enumerate(loaded):
        converted = in_unit(d, target)
        if converted is None or converted is d:
            continue
        loaded[k] = (path, converted)
        note(args, f'note: {path} has its position in {d.position_unit}: converted to '
                   f'{target}, the unit of {source} (1 {d.position_unit} = '
                   f'{unit_factor(d.position_unit, target):.6g} {target})')


def join_records(args: argparse.Namespace, loaded: List[Tuple[str, Any]],
                 **lead: Any) -> Any:
    """Return the checked records joined (`records.join`), the held-out ones last."""
    from ..records import join
    if not loaded[0][1].joinable:
        return loaded[0][1]
    held = list(getattr(args, 'validate_on', None) or [])
    if not held and len(loaded) > 1 and getattr(args, 'command', '') != 'compare':
        held = [loaded[-1][0]]
    notes = []
    data = join(loaded, held_out=tuple(held), notes=notes, **lead)
    for line in notes:
        note(args, line)
    return data


def data_lines(data: Any, role: Optional[str] = None) -> List[str]:
    """Return one line per record of `data`: 'NAME (role): dynamic record: ...' if joined."""
    return DATA_KINDS[data.kind].lines(data, role)


def record_lines(data: DynamicData, role: Optional[str] = None) -> List[str]:
    """Return one line per joined record of `data`: name, role (`role` if given), description."""
    from ..data import describe
    from ..records import segment_view
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

    lines = staticmethod(record_lines)

    @staticmethod
    def records(data: DynamicData, prediction: np.ndarray, split: Optional[Split] = None,
                role: Optional[str] = None) -> List[Dict[str, Any]]:
        """
        Return the per-record scores of `prediction` (`engine.record_scores`).

        Compared records also get their `start_offset` (`records.start_offsets`).
        """
        from ..engine import record_scores
        from ..records import start_offsets
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
        from ..data import describe
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


# the command-line handling of each data kind (like workbench.compare's _VIEWS)
DATA_KINDS = {DynamicData.kind: _DynamicKind, StaticData.kind: _StaticKind}


def read_model_spec(path: str, catalog: Optional[Mapping[str, Any]]) -> Dict[str, Any]:
    """Return MODEL.yaml as a checked dict (effects known to the catalog; None: any name)."""
    from ...core.model_file import read_model
    return read_model(path, known_effects=catalog)


def read_fitted_spec(path: str, catalog: Optional[Mapping[str, Any]]) -> Dict[str, Any]:
    """Return `read_model_spec` of a fit's model file; refuse a file without a fitted model."""
    from ...core.model_file import is_fitted
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
        from ...core.actuator import simulate
        tr = simulate(params, data.duty_a, data.duty_b, data.dt, ambient_c=data.ambient)
        return {'theta_a': tr.theta_a_c, 'theta_b': tr.theta_b_c}
    return {}


def print_json(obj: Any) -> None:
    """Print strict JSON (no NaN) to stdout (`core.model_file.json_safe`)."""
    from ...core.model_file import json_safe
    print(json.dumps(json_safe(obj), indent=2, allow_nan=False))


def model_line(effects: Sequence[str], kind: str) -> str:
    """Return 'modified PI base + saturation, delay' ('... (the paper's model)' if none)."""
    if effects:
        return f'{kind} PI base + {", ".join(effects)}'
    return f'{kind} PI base' + (" (the paper's model)" if kind == 'modified' else '')


def noise_score_line(floor: Optional[float], data: Any, scores: Dict[str, Optional[dict]],
                     unit: str) -> Optional[str]:
    """
    Return the noise's score line (`remaining.noise_line`), None where `floor` is None.

    floor: `engine.noise_floor(data)`; scores: {part: scores dict or None}; a held-out part too
    narrow to score (`"informative": false`) is left out, as its score line leaves it
    unscored.
    """
    shown = ((p, scores.get(p)) for p in ('train', 'validation', 'all'))
    nrmse = {p: s.get('nrmse') for p, s in shown if s and s.get('informative', True)}
    return noise_line(floor, data.span(), nrmse, unit) if floor else None


def tau_profile_doc(args: argparse.Namespace, data: Any, fit: Any,
                    progress: Progress) -> Dict[str, Any]:
    """
    Return {'tau_profile': ...} for a dynamic fit ({} for curves).

    Two more fits with the thermal time constant held (`identifiability.tau_profile`).
    """
    from ..identifiability import tau_profile
    if getattr(data, 'kind', None) != DynamicData.kind or 'tau_s' not in fit.values:
        return {}
    profile = tau_profile(data, fit, jobs=args.jobs, progress=progress)
    return {'tau_profile': profile.to_json()}


def duty_levels_doc(data: Any, fit: Any) -> Dict[str, Any]:
    """Return {'duty_levels': ...} of a dynamic fit's training samples ({} for curves)."""
    from ..levels import duty_levels
    dynamic = getattr(data, 'kind', None) == DynamicData.kind
    levels = duty_levels(data, fit.split) if dynamic else None
    return {'duty_levels': levels.to_json()} if levels else {}


def fitted_model(args: argparse.Namespace, spec: Mapping[str, Any], data: Any = None) -> Any:
    """Return the model file's fit (`engine.load_fit`), scored on `data` if given."""
    from ..engine import load_fit
    try:
        return load_fit(spec, data=data)
    except (KeyError, TypeError, ValueError) as err:
        what = f'missing {err}' if isinstance(err, KeyError) else str(err)
        raise UsageError(f'{args.model}: cannot use the fitted model ({what})') from None


def try_lead_in(args: argparse.Namespace, loaded: List[Tuple[str, Any]], fit: Any, data: Any,
                refit: Callable[..., tuple]) -> Tuple[Optional[tuple], Dict[str, Any]]:
    """Return `leadins.refit_led` of the first `fit`, noting the lead-ins it keeps."""
    from ..leadins import refit_led
    led, lead = refit_led(fit, data, loaded, refit)
    note_lead_in(args, lead, loaded)
    return led, lead


def lead_in_lines(lead: Dict[str, Any], loaded: List[Tuple[str, Any]]) -> List[str]:
    """Return a line for each record led in (warm or cooling), and for a longer rest."""
    from ..records import REST_GAP_S, REST_TAUS, rest_gap_s
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
        note(args, f'note: {line}')
    return lines


def _lead_in_words(d: Any, lead_in: tuple, lead: Dict[str, Any]) -> str:
    """Return how record `d` starts and is simulated, by its (duty_a, duty_b, first_s)."""
    from ..records import rest_gap_s, starts_heated
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
