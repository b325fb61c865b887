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
Fit, compare and diagnose many recordings at once on a Dask cluster (`sma-model batch`).

Each record is one task that runs `sma-model diagnose`'s own rounds
(`diagnosis.diagnose_rounds`) and hands every candidate refit back to the cluster as a task
of its own, so a large cluster spreads one record's refits over its workers, not only
whole records:

    record task: base fit -> [refit per candidate effect, as cluster tasks] -> rank
                 -> [next round from the named candidate's refit] -> report

A round adds the named effect and diagnoses again (`--rounds`). Workers read each record
by its path and write its report under ``OUT/records/<key>/``; only the per-record result
(scores, named effects, fitted parameters, a few kB) travels back to the client, which
keeps one ``result.json`` per record and rebuilds the fleet table from them. The table
therefore always holds exactly the records finished so far, also after Ctrl-C, and a
rerun skips every record whose result matches the file and the options.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from functools import lru_cache, partial
import glob
import hashlib
import json
import logging
import os
from pathlib import Path
import sys
import time
from typing import (Any, Iterable, Iterator, List, Optional, TextIO, TYPE_CHECKING,
                    Union)
import warnings

from .limits import MAX_FIT_RATE_HZ

if TYPE_CHECKING:
    from dask.distributed import Client, Future

    from ..core.datakinds import DynamicData, StaticData

RESULT_FILE = 'result.json'
TABLE_NAME = 'batch'
RECORD_SUFFIXES = ('.csv', '.mcap')
# thermal and shaft parameters of the fitted base model put in the table [units in names]
BASE_PARAMETERS = ('stroke_rad', 'offset_rad')
RECORD_COLUMNS = ('samples', 'duration_s', 'rate_hz', 'layout', 'position_unit',
                  'reference_nrmse', 'lead_in_duty_a', 'lead_in_duty_b',
                  'lead_in_first_duties_s', 'notes')


class BatchError(ValueError):
    """A batch cannot start as asked (no records, bad output directory); one line."""


@dataclass(frozen=True)
class BatchOptions:
    """What is done to every record (part of each result's fingerprint)."""

    effects: tuple = ()          # effects of the starting model (from --model)
    kind: str = None             # hysteresis base: 'classical' | 'modified' | None (default)
    candidates: tuple = None     # candidate effects for diagnose (None: the whole catalog)
    rounds: int = 1              # diagnose rounds: add the named effect and diagnose again
    rate_hz: float = None        # resampling rate for bags [Hz] (None: joint-state rate)
    max_rate_hz: float = MAX_FIT_RATE_HZ   # faster records are decimated to this rate [Hz]
    reports: bool = True         # write an HTML report per record
    reference: dict = None       # a fitted model (from fit --out) compared with every record
    position_unit: str = None    # overrides the unit the records name (--position-unit)
    default_unit: str = 'rad'    # the unit of a record that names none (the model's, else rad)
    layout: str = None           # 'single' | 'antagonistic' (None: from each record's duties)
    columns: tuple = ()          # a CSV's own column names, 'NAME=HEADER' texts (--column)
    keep_glitches: bool = False  # read sensor glitches as measured (--keep-glitches)
    # --plugin specs loaded on every worker, each with a hash of its file (`worker_plugins`)
    plugins: tuple = ()

    def fingerprint(self) -> str:
        """
        Return a short hash of the options; a result made with other options is recomputed.

        The reading options at their defaults are left out, so results written before
        those options existed still match.
        """
        doc = {k: v for k, v in asdict(self).items()
               if k not in READING_DEFAULTS or v != READING_DEFAULTS[k]}
        return hashlib.sha1(json.dumps(doc, sort_keys=True).encode()).hexdigest()[:12]

    def reading(self) -> tuple:
        """Return how a record is read, hashable (the cache key of `_load`)."""
        return (self.rate_hz, self.max_rate_hz, self.position_unit, self.default_unit,
                self.layout, tuple(self.columns), self.keep_glitches)


READING_DEFAULTS = {'position_unit': None, 'default_unit': 'rad', 'layout': None,
                    'columns': (), 'keep_glitches': False, 'plugins': ()}


# ------------------------------------------------------------------------------ records
def find_records(specs: Iterable[str]) -> List[Path]:
    """
    Expand DATA arguments (files, bag directories, directories, globs) into record paths.

    A directory is a bag if it holds a metadata.yaml or an .mcap file; otherwise it is
    searched recursively for CSV files, .mcap files and bag directories. Raises
    `BatchError` for an argument that matches nothing.
    """
    from .data import is_bag
    found = []
    for spec in specs:
        matches = sorted(glob.glob(spec, recursive=True)) if glob.has_magic(spec) else [spec]
        if not matches or not all(Path(m).exists() for m in matches):
            raise BatchError(f'{spec}: no such file, directory or matching path')
        for match in map(Path, matches):
            found += [match] if match.is_file() or is_bag(match) else _records_in(match)
    unique = list(dict.fromkeys(p.resolve() for p in found))
    if not unique:
        raise BatchError(f'no records (CSV files or MCAP bags) in {", ".join(specs)}')
    return unique


def _records_in(directory: Union[str, Path]) -> List[Path]:
    """Return the records under `directory`: CSV and .mcap files and bag directories."""
    from .data import is_bag
    out = []
    for root, dirs, files in os.walk(directory):
        root = Path(root)
        bags = [d for d in dirs if is_bag(root / d)]
        out += [root / d for d in bags]
        dirs[:] = sorted(d for d in dirs if d not in bags)
        out += [root / f for f in sorted(files) if f.lower().endswith(RECORD_SUFFIXES)]
    return out


def record_key(path: Union[str, Path]) -> str:
    """Return a record's result directory name: its stem and a hash of its absolute path."""
    path = Path(path).resolve()
    stem = ''.join(c if c.isalnum() or c in '-_' else '_' for c in path.stem)[:40]
    return f'{stem}-{hashlib.sha1(str(path).encode()).hexdigest()[:8]}'


def file_fingerprint(path: Union[str, Path]) -> str:
    """Return a hash of a record's sizes and modification times (every file of a bag)."""
    path = Path(path)
    files = sorted(p for p in path.rglob('*') if p.is_file()) if path.is_dir() else [path]
    h = hashlib.sha1()
    for f in files:
        st = f.stat()
        h.update(f'{f.name}:{st.st_size}:{st.st_mtime_ns};'.encode())
    return h.hexdigest()[:12]


# ------------------------------------------------------------------------------ worker tasks
def worker_plugins(specs: Optional[Iterable[str]]) -> tuple:
    """
    Return the --plugin specs as every worker loads them: ((spec, content hash), ...).

    A file is named by its absolute path (a worker may run elsewhere: the file must be at
    that path there) and carries a hash of its text, so that results made with another
    version of the plug-in are recomputed (`BatchOptions.fingerprint`); a module name
    carries ''.
    """
    from .plugins import is_file_spec
    out = []
    for spec in specs or ():
        path = Path(spec)
        if is_file_spec(spec):
            text = path.read_bytes() if path.is_file() else b''
            out.append((str(path.resolve()), hashlib.sha1(text).hexdigest()[:12]))
        else:
            out.append((spec, ''))
    return tuple(out)


@lru_cache(maxsize=None)
def register_effects(plugins: tuple) -> None:
    """
    Register the entry-point effects and `plugins` (`worker_plugins`) in this process, once.

    A worker process starts with the package's catalog only: what the client registered
    (`commands.steps.setup_effects`) is registered here too before a record's first fit.
    """
    from . import plugins as plugin_loader
    plugin_loader.load_entry_points()
    plugin_loader.load_plugins([spec for spec, _ in plugins])


@lru_cache(maxsize=4)
def _read(path: str, reading: tuple, stamp: str) -> tuple:
    """
    Read and check one record on a worker, as `sma-model fit` reads it: (data, notes).

    Cached, since every candidate task of a record reads it; `stamp` is the file
    fingerprint, so a changed file is read again. reading: `BatchOptions.reading` (the
    bags' resampling rate [Hz] or None, the fitting rate's limit [Hz]
    (`records.at_fit_rate`), the position unit, the unit of a record that names none, the
    layout, the --column texts, whether glitches are kept). notes: the lines `fit` prints
    about the reading (values held or bridged, a clock resampled, a bag recovered, a record
    decimated, glitches bridged), without the record's path.
    """
    from .data import apply_layout, check_excitation, load_data, parse_column_map
    from .records import at_fit_rate
    rate_hz, max_rate_hz, unit, default_unit, layout, columns, keep_glitches = reading
    notes = []
    data, note = at_fit_rate(load_data(path, rate_hz=rate_hz, position_unit=unit,
                                       default_unit=default_unit, notes=notes,
                                       renames=parse_column_map(columns),
                                       keep_glitches=keep_glitches), max_rate_hz)
    check_excitation(data, path)
    apply_layout(data, layout, path)
    notes += [note] if note else []
    return data, tuple(n[len(path) + 2:] if n.startswith(f'{path}: ') else n for n in notes)


@lru_cache(maxsize=4)
def _load(path: str, reading: tuple, stamp: str,
          lead: tuple = ()) -> Union[DynamicData, StaticData]:
    """
    Return the record read by `_read`, led in as `lead` says.

    lead: the record's lead-in as `lead_items` gives it (() for none): the record read is
    joined with it (cached too).
    """
    from .records import join
    data = _read(path, reading, stamp)[0]
    return join([(path, data)], **_lead_options(lead)) if lead else data


def lead_items(lead: dict) -> tuple:
    """Return `records.join`'s lead options as a hashable tuple (the cache key of `_load`)."""
    return tuple((k, tuple(v.items()) if isinstance(v, dict) else v)
                 for k, v in sorted(lead.items()))


def _lead_options(items: tuple) -> dict:
    """Return the `records.join` lead options of `lead_items`."""
    return {k: dict(v) if isinstance(v, tuple) else v for k, v in items}


def task_record(path: str, stamp: str, options: BatchOptions, report_dir: str) -> dict:
    """
    Worker: fit the record, diagnose it in rounds, write its report.

    A record that does not start at rest (a chunk of a longer log) is led in, as `sma-model
    diagnose` does (`leadins.refit_led`). The rounds are `diagnosis.diagnose_rounds` (the one
    implementation `sma-model diagnose` uses); its candidate refits go back to the cluster as
    tasks of their own, so one record's refits spread over the workers. Returns {'rounds':
    [round summary, ...], 'parameters': the final model's parameters {name: value}, units in
    the names}.
    """
    from dask.distributed import worker_client
    from .data import describe
    from .diagnosis import diagnose_rounds
    from .report import write_diagnosis_report
    register_effects(options.plugins)
    started = time.perf_counter()
    reading = options.reading()
    data, base, lead = _fit_led(path, reading, stamp, options)
    record = dict(data.columns(), **lead_columns(path, lead),
                  notes='; '.join(_read(path, reading, stamp)[1]) or None)
    if options.reference is not None:
        record['reference_nrmse'] = compare_reference(options.reference, data)
    base_seconds = time.perf_counter() - started
    # the worker's thread is handed back while this task waits for its refits
    with worker_client() as client:
        mapper = partial(_judge_on_cluster, client, path, stamp, reading, lead_items(lead))
        diags, _, final = diagnose_rounds(data, base, options.rounds,
                                          candidates=_candidates(options), mapper=mapper)
    rounds = [round_summary(diag, record, base_seconds if i == 0 else 0.0)
              for i, diag in enumerate(diags)]
    if options.reports:
        Path(report_dir).mkdir(parents=True, exist_ok=True)
        write_diagnosis_report(report_dir, data, diags[-1],
                               f'sma-model batch: {Path(path).name}', describe(data),
                               force=True)
    return {'rounds': rounds, 'parameters': final_parameters(final)}


def _fit_led(path: str, reading: tuple, stamp: str, options: BatchOptions) -> tuple:
    """Return (data, base fit, lead) of the record, led in if it does not start at rest."""
    from .engine import fit_model
    from .leadins import refit_led
    data = _load(path, reading, stamp)
    base = fit_model(data, effects=tuple(options.effects), kind=options.kind)

    def refit(**lead: Any) -> tuple:
        led = _load(path, reading, stamp, lead_items(lead))
        return led, fit_model(led, effects=tuple(options.effects), kind=options.kind)
    led, lead = refit_led(base, data, [(path, data)], refit)
    return led + (lead,) if led else (data, base, {})


def lead_columns(path: str, lead: dict) -> dict:
    """Return the record's lead-in columns: its duties [0-1] held and the time [s] led in."""
    duty_a, duty_b, first_s = lead.get('lead_in', {}).get(path, (None,) * 3)
    return {'lead_in_duty_a': duty_a, 'lead_in_duty_b': duty_b,
            'lead_in_first_duties_s': first_s}


def _judge_on_cluster(client: Client, path: str, stamp: str, reading: tuple, lead: tuple,
                      tasks: list) -> Iterator[dict]:
    """
    Yield the `judging.judge_candidate` entries of `tasks`, each refit a cluster task.

    The tasks travel without the record: each worker reads it by its path (cached), and
    leads it in as `lead` (`lead_items`) says.
    """
    from dask.distributed import as_completed
    futures = [client.submit(task_candidate, path, stamp, reading, task[1:], lead, pure=False)
               for task in tasks]
    for fut in as_completed(futures):
        yield fut.result()


def task_candidate(path: str, stamp: str, reading: tuple, task: tuple,
                   lead: tuple = ()) -> dict:
    """Run one `judging.judge_candidate` task (without its data) on the record at `path`."""
    from .judging import judge_candidate
    return judge_candidate((_load(path, reading, stamp, lead),) + tuple(task))


def compare_reference(spec: dict, data: Any) -> Optional[float]:
    """
    Return the NRMSE of a fitted model (`sma-model fit --out` spec) over the whole record.

    A record in another unit of the same quantity (um beside the model's mm) is converted
    into the model's, as `sma-model compare` converts it
    (`commands.steps.convert_to_one_unit`). None for a record of another rig: its layout, or
    its position's quantity, is not the model's.
    """
    from .units import in_unit
    from .engine import load_fit
    data = in_unit(data, spec.get('position_unit') or data.position_unit)
    if data is None or spec.get('layout') not in (None, data.layout):
        return None
    return float(load_fit(spec, data=data).validation['nrmse'])


def round_summary(diag: Any, record: dict, base_seconds: float = 0.0) -> dict:
    """
    Return one round's summary: its model, the effect it named and the best candidate.

    seconds: the base fit's (`base_seconds`, the first round's) plus every refit's;
    refitted: why the round's base was refitted before it was diagnosed, or None;
    training_lead: the effect of `Diagnosis.training_lead`, a hint where nothing is named.
    """
    fit = diag.baseline
    best = next((c for c in diag.candidates if c['effect'] == diag.missing_effect), None)
    return {'effects': list(fit.effects), 'named': diag.missing_effect,
            'validation_nrmse': fit.validation['nrmse'], 'train_nrmse': fit.train['nrmse'],
            'noise_floor_nrmse': diag.noise_floor_nrmse,
            'improvement': best['improvement'] if best else None,
            'named_validation_nrmse': best['validation_nrmse'] if best else None,
            'best_candidate': diag.candidates[0]['effect'] if diag.candidates else None,
            'best_improvement': diag.candidates[0]['improvement'] if diag.candidates else None,
            'seconds': (base_seconds + diag.earlier_seconds
                        + sum(c.get('seconds', 0.0) for c in diag.candidates)),
            'refitted': diag.refitted or None, 'record': record,
            'training_lead': diag.training_lead['effect'] if diag.training_lead else None}


def final_parameters(fit: Any) -> dict:
    """
    Return the fitted parameters of `fit` as {name: value}, units in the names.

    A position is named in the record's unit (`actuator.name_in_unit`: stroke_mm).
    """
    from ..core.actuator import name_in_unit
    values = {k: float(v) for k, v in fit.values.items()}
    params = getattr(fit, 'params', None)
    for name in BASE_PARAMETERS:
        if hasattr(params, name):
            values[name] = float(getattr(params, name))
    if hasattr(params, 'heat_capacity_j_per_k'):
        values['tau_s'] = float(params.heat_capacity_j_per_k / params.conductance_w_per_k)
    unit = getattr(fit, 'rig', {}).get('position_unit', '')
    return {name_in_unit(k, unit): v for k, v in values.items()}


# ------------------------------------------------------------------------------ client
class RecordRun:
    """The client's state of one record: its result so far."""

    def __init__(self, path: Path, options: BatchOptions, out_dir: Path) -> None:
        """Name the record's result directory and fingerprint its file."""
        self.path = Path(path)
        self.key = record_key(path)
        self.dir = Path(out_dir) / 'records' / self.key
        self.stamp = file_fingerprint(path)
        self.options = options
        self.rounds = []
        self.started = time.perf_counter()

    def submit(self, client: Client) -> Future:
        """Submit the record's task (fit, diagnose rounds, report)."""
        return client.submit(task_record, str(self.path), self.stamp, self.options,
                             str(self.dir / 'report'), key=f'record-{self.key}', pure=False)

    def result(self, parameters: Optional[dict] = None, error: Optional[str] = None) -> dict:
        """Return the record's result document (one table row plus its rounds)."""
        first = self.rounds[0] if self.rounds else {}
        named = [r['named'] for r in self.rounds if r['named']]
        return {'record': str(self.path), 'key': self.key,
                'file_fingerprint': self.stamp, 'options': self.options.fingerprint(),
                'error': error,
                'base_effects': ' '.join(self.options.effects),
                'base_train_nrmse': first.get('train_nrmse'),
                'base_validation_nrmse': first.get('validation_nrmse'),
                'noise_floor_nrmse': first.get('noise_floor_nrmse'),
                'named_effect': named[0] if named else None,
                'improvement': first.get('improvement'),
                'effects_added': ' '.join(named),
                'final_validation_nrmse': _final_nrmse(self.rounds),
                'training_lead': self.rounds[-1].get('training_lead') if self.rounds else None,
                'task_time_s': sum(r['seconds'] for r in self.rounds),
                'wall_time_s': time.perf_counter() - self.started,
                'report': (str(Path('records') / self.key / 'report' / 'index.html')
                           if parameters is not None and self.options.reports else None),
                'parameters': parameters or {},
                'rounds': [{k: v for k, v in r.items() if k != 'record'} for r in self.rounds],
                **{k: first.get('record', {}).get(k) for k in RECORD_COLUMNS}}


def _final_nrmse(rounds: List[dict]) -> Optional[float]:
    """
    Return the validation NRMSE of the final model.

    The final model is the last round's refit with the effect it named, or its base if
    it named none.
    """
    if not rounds:
        return None
    last = rounds[-1]
    return last['named_validation_nrmse'] if last['named'] else last['validation_nrmse']


def _candidates(options: BatchOptions) -> Optional[list]:
    """Return the candidate effects of the options (None: the whole catalog)."""
    return list(options.candidates) if options.candidates else None


def load_result(directory: Union[str, Path], stamp: str,
                options: BatchOptions) -> Optional[dict]:
    """Return a finished record's result from a previous run, or None (missing, stale, failed)."""
    path = Path(directory) / RESULT_FILE
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if (doc.get('error') or doc.get('file_fingerprint') != stamp
            or doc.get('options') != options.fingerprint()):
        return None
    return doc


def save_result(directory: Union[str, Path], doc: dict) -> None:
    """Write a record's result atomically (a reader never sees half a file)."""
    from ..core.model_file import json_safe
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    tmp = directory / (RESULT_FILE + '.tmp')
    tmp.write_text(json.dumps(json_safe(doc), indent=1, allow_nan=False))
    tmp.replace(directory / RESULT_FILE)


def error_line(err: BaseException) -> str:
    """Return one line for a record's failure: the exception's type and message."""
    text = ' '.join(str(err).split()) or type(err).__name__
    return text if isinstance(err, ValueError) else f'{type(err).__name__}: {text}'


class BatchProgress:
    """
    Records done, errors and the time left, on stderr.

    A bar on a terminal, else a line per finished record (so it shows in a log).
    """

    def __init__(self, total: int, stream: Optional[TextIO] = None) -> None:
        """Start the clock for `total` records, written to `stream` (default stderr)."""
        self.total, self.done, self.errors = total, 0, 0
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, 'isatty', lambda: False)())
        self.started = time.perf_counter()

    def record_done(self, name: str, error: Optional[str] = None,
                    skipped: bool = False) -> None:
        """Count one record and draw the progress."""
        self.done += 1
        self.errors += bool(error)
        elapsed = time.perf_counter() - self.started
        left = elapsed / self.done * (self.total - self.done)
        status = 'skipped (done before)' if skipped else ('error' if error else 'done')
        text = (f'batch: {self.done}/{self.total} records, {self.errors} errors, '
                f'{_duration(elapsed)} elapsed, about {_duration(left)} left; {name}: {status}')
        if self.tty:
            self.stream.write('\r\033[K' + text + ('\n' if self.done == self.total else ''))
        else:
            self.stream.write(text + '\n')
        self.stream.flush()


def _duration(seconds: float) -> str:
    """Return `seconds` as 'N s' or 'N min SS s'."""
    seconds = int(round(seconds))
    return f'{seconds // 60} min {seconds % 60:02d} s' if seconds >= 60 else f'{seconds} s'


def start_client(scheduler: Optional[str] = None,
                 workers: Optional[int] = None) -> Client:
    """
    Return a `dask.distributed.Client`.

    The client is on a running scheduler, or on a local cluster of `workers`
    single-threaded processes (default: every core).
    """
    from dask.distributed import Client, LocalCluster
    from .parallel import available_cores
    if scheduler:
        return Client(scheduler, timeout='30s')
    with warnings.catch_warnings():
        # without a dashboard the scheduler still serves its HTTP routes; when another
        # cluster holds the default port it takes a free one, which is nothing to warn of
        warnings.filterwarnings('ignore', message='Port .* is already in use',
                                category=UserWarning)
        cluster = LocalCluster(n_workers=workers or available_cores(), threads_per_worker=1,
                               processes=True, dashboard_address=None,
                               silence_logs=logging.CRITICAL)
    return Client(cluster)


def run_batch(paths: Iterable[Union[str, Path]], out_dir: Union[str, Path],
              options: BatchOptions, client: Client, force: bool = False,
              progress: Optional[BatchProgress] = None,
              results: Optional[List[dict]] = None) -> List[dict]:
    """
    Run every record through its rounds on `client`; returns the result documents.

    Results already in `out_dir` are kept unless `force`. `results`: a list the documents
    are appended to as each record ends (after its result.json is written), so that a
    caller interrupted by Ctrl-C still holds every finished record.
    """
    from dask.distributed import as_completed
    runs = {}
    results = [] if results is None else results
    pending = as_completed()
    for path in paths:
        run = RecordRun(path, options, out_dir)
        done = None if force else load_result(run.dir, run.stamp, options)
        if done is not None:
            results.append(done)
            if progress:
                progress.record_done(run.path.name, skipped=True)
            continue
        fut = run.submit(client)
        runs[fut.key] = run
        pending.add(fut)
    for fut in pending:
        run = runs.pop(fut.key)
        try:
            value = fut.result()
        except Exception as err:   # any failure of one record is that record's error row
            doc = run.result(error=error_line(err))
        else:
            run.rounds = value['rounds']
            doc = run.result(parameters=value['parameters'])
        save_result(run.dir, doc)
        results.append(doc)
        if progress:
            progress.record_done(run.path.name, error=doc['error'])
    return results
