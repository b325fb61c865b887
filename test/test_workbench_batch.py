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
"""`sma-model batch`: a fleet of records on a Dask cluster, error rows, resumption."""
import contextlib
import csv
import json
import os
import socket
import warnings

import numpy as np
import pyarrow.parquet as pq
import pytest
from sma_actuator.bag.synthetic import SMA_TOPICS, stamp, to_cdr
from sma_actuator.bag.writer import BagWriter
from sma_actuator.core.actuator import ActuatorParams, simulate
from sma_actuator.core.excitation import multilevel
from sma_actuator.workbench import batch, cli
from sma_actuator.workbench.fleet import effect_recurrence, table_rows
from support.plugin_effect import DEAD_TIME_PLUGIN, install_entry_point

N_DELAY, N_NONE = 7, 7
N_RECORDS = N_DELAY + N_NONE + 3   # and a good bag, a corrupt bag, a malformed CSV
DURATION_S, RATE_HZ, DELAY_S = 120.0, 10.0, 0.8
COLUMNS = ('time', 'duty_a', 'duty_b', 'position')
T0_NS = 1_700_000_000_000_000_000
DUTY, JOINT_STATE = (SMA_TOPICS[topic][0] for topic in ('/sma/duty', '/sma/joint_states'))


def _record(effect, seed, warm_s=None, dead_duty=0.0):
    """
    Return a short identification run of the package's plant model.

    Multilevel excitation, as the controller's model is identified from, and 2 mrad noise;
    `effect` 'delay' is a 0.8 s transport delay. warm_s [s]: the log begins 1 s after the
    first duty came on, that duty having been on for warm_s before (a chunk of a longer log).
    dead_duty: the PWM dead time of the plug-in effect (`support.plugin_effect`).
    """
    dt = 1.0 / RATE_HZ
    duty_a, duty_b = multilevel(DURATION_S + (10.0 if warm_s else 0.0), dt, seed=seed)
    warm = 0
    if warm_s:
        first = np.flatnonzero((duty_a > 0) | (duty_b > 0))[0] + int(round(1.0 / dt))
        warm = int(round(warm_s / dt))
        duty_a, duty_b = (np.r_[np.full(warm, d[first]), d[first:]] for d in (duty_a, duty_b))
    params = ActuatorParams(delay_s=DELAY_S if effect == 'delay' else 0.0)
    heat = (np.clip((d - dead_duty) / (1 - dead_duty), 0, 1) for d in (duty_a, duty_b))
    position = simulate(params, *heat, dt).position_rad[warm:]
    rng = np.random.default_rng(seed)
    return {'time': np.arange(len(position)) * dt, 'duty_a': duty_a[warm:],
            'duty_b': duty_b[warm:], 'position': position + rng.normal(0.0, 0.002, len(position))}


def _write_csv(path, rec):
    np.savetxt(path, np.column_stack([rec[c] for c in COLUMNS]), delimiter=',',
               header=','.join(COLUMNS), comments='', fmt='%.6g')


def _write_bag(path, rec):
    """Return the record as the recorder would store it: joint states and duty commands."""
    written = []   # (topic, type, message, time [ns])
    for t, da, db, pos in zip(*(rec[c] for c in COLUMNS)):
        ns = T0_NS + int(round(t * 1e9))
        written.append(('/sma/duty', DUTY, {'data': [float(da), float(db)]}, ns - 1000))
        written.append(('/sma/joint_states', JOINT_STATE, {
            'header': {'stamp': stamp(ns)}, 'name': ['shaft'], 'position': [float(pos)],
            'velocity': [0.0]}, ns))
    payloads = to_cdr([(type_name, msg) for _, type_name, msg, _ in written])
    with BagWriter(path) as bag:
        bag.add_topic('/sma/joint_states', JOINT_STATE)
        bag.add_topic('/sma/duty', DUTY)
        for (topic, _, _, ns), data in zip(written, payloads):
            bag.write(topic, data, ns)
    return path


@pytest.fixture(scope='module')
def fleet(tmp_path_factory):
    """
    17 records.

    Delay (0.8 s) and effect-free CSVs, one good and one corrupt bag, one malformed CSV. Returns
    (directory, {file name: hidden effect or 'error'}).
    """
    root = tmp_path_factory.mktemp('fleet')
    truth = {}
    for i in range(N_DELAY):
        _write_csv(root / f'delay_{i:02d}.csv', _record('delay', i))
        truth[f'delay_{i:02d}.csv'] = 'delay'
    for i in range(N_NONE):
        _write_csv(root / f'none_{i:02d}.csv', _record('none', 100 + i))
        truth[f'none_{i:02d}.csv'] = None
    bags = root / 'bags'
    bags.mkdir()
    _write_bag(bags / 'delay_bag', _record('delay', 50))
    truth['delay_bag'] = 'delay'
    corrupt = _write_bag(bags / 'corrupt_bag', _record('none', 51))
    mcap = next(corrupt.glob('*.mcap'))
    mcap.write_bytes(mcap.read_bytes()[:300])
    truth['corrupt_bag'] = 'error'
    (root / 'malformed.csv').write_text('time,duty_a,duty_b,position\n0,0,0,0\n0.1,0.5,x,0\n')
    truth['malformed.csv'] = 'error'
    return root, truth


@pytest.fixture(scope='module')
def scheduler():
    """Return a running two-worker Dask cluster, used through --scheduler ADDRESS."""
    from dask.distributed import LocalCluster
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=50)
    yield cluster.scheduler_address
    cluster.close()


@pytest.mark.slow
def test_a_record_begun_mid_run_is_led_in_as_diagnose_leads_it(scheduler, tmp_path):
    root = tmp_path / 'records'
    root.mkdir()
    _write_csv(root / 'warm.csv', _record('delay', 7, warm_s=30.0))
    _write_csv(root / 'rest.csv', _record('delay', 8))
    out = tmp_path / 'out'
    argv = ['batch', str(root), '--out', str(out), '--candidates', 'delay', '--no-reports',
            '--scheduler', scheduler]
    assert cli.main(argv) == 0
    rows = {_name(r['record']): r for r in pq.read_table(out / 'batch.parquet').to_pylist()}
    warm, rest = rows['warm.csv'], rows['rest.csv']
    # led in warm: rest (zero duties held), then its first duties on for a while
    assert warm['lead_in_duty_a'] == warm['lead_in_duty_b'] == 0.0
    assert warm['lead_in_first_duties_s'] > 1.0
    assert rest['lead_in_duty_a'] is None and rest['lead_in_first_duties_s'] is None
    # the candidate refits ran on the led-in record too
    assert warm['named_effect'] == rest['named_effect'] == 'delay'
    assert 0.6 < warm['param.delay_s'] < 1.0
    assert warm['final_validation_nrmse'] < 0.05


def _name(record):
    parts = record.split('/')
    return parts[-1] if parts[-1] in ('delay_bag', 'corrupt_bag') or '.' in parts[-1] \
        else parts[-2]


class _StopAfter(batch.BatchProgress):
    """Progress that presses Ctrl-C after a number of records."""

    limit = 10

    def record_done(self, name, error=None, skipped=False):
        super().record_done(name, error, skipped)
        if self.done >= self.limit:
            raise KeyboardInterrupt


@pytest.mark.slow
def test_batch_names_the_hidden_effects_keeps_errors_and_resumes(fleet, scheduler, tmp_path,
                                                                 monkeypatch, capsys):
    root, truth = fleet
    out = tmp_path / 'out'
    argv = ['batch', str(root), '--out', str(out), '--candidates', 'delay', '--no-reports',
            '--scheduler', scheduler]
    monkeypatch.setattr(batch, 'BatchProgress', _StopAfter)
    assert cli.main(argv) == cli.EXIT_INTERRUPTED
    first = pq.read_table(out / 'batch.parquet').to_pylist()
    on_disk = list(out.glob('records/*/result.json'))
    # the table holds exactly the records finished before Ctrl-C, each complete
    assert len(first) == len(on_disk) >= _StopAfter.limit
    assert all(r['record'] and (r['error'] or r['base_validation_nrmse'] is not None)
               for r in first)
    capsys.readouterr()

    monkeypatch.undo()
    assert cli.main(argv + ['--json']) == 0
    captured = capsys.readouterr()
    rows = pq.read_table(out / 'batch.parquet').to_pylist()
    assert len(rows) == len(truth) == N_RECORDS
    assert {_name(r['record']) for r in rows} == set(truth)
    # finished records were skipped, not recomputed (errors are retried)
    done_before = sum(1 for r in first if not r['error'])
    assert captured.err.count('skipped (done before)') == done_before
    errors = {_name(r['record']): r['error'] for r in rows if r['error']}
    assert set(errors) == {'corrupt_bag', 'malformed.csv'}
    assert all('\n' not in e and _name_in(e, n) for n, e in errors.items())
    named = {_name(r['record']): r['named_effect'] for r in rows if not r['error']}
    wrong = {n: e for n, e in named.items() if e != truth[n]}
    assert not wrong, f'named effects differ from the hidden ones: {wrong}'
    with open(out / 'batch.csv', newline='') as fh:
        assert len(list(csv.DictReader(fh))) == N_RECORDS
    # the 2 mrad of noise is found in every record, below its base model's error
    assert all(0 < r['noise_floor_nrmse'] < 1.5 * r['base_validation_nrmse']
               for r in rows if not r['error'])
    fitted = [r for r in rows if r['named_effect'] == 'delay']
    assert all(0.6 < r['param.delay_s'] < 1.0 for r in fitted)
    assert all(r['final_validation_nrmse'] < r['base_validation_nrmse'] for r in fitted)
    summary = json.loads(captured.out)
    assert summary['records'] == N_RECORDS and summary['errors'] == 2
    index = (out / 'index.html').read_text()
    assert 'delay' in index and 'malformed.csv' in index and 'parameters.png' in index


def _name_in(error, name):
    return name.split('.')[0] in error


@pytest.mark.slow
def test_batch_rounds_write_reports_linked_from_the_index(fleet, scheduler, tmp_path):
    root, _ = fleet
    out = tmp_path / 'out'
    argv = ['batch', str(root / 'delay_00.csv'), str(root / 'none_0[01].csv'),
            '--out', str(out),
            '--candidates', 'delay', 'asymmetric_wires', '--rounds', '2',
            '--scheduler', scheduler]
    assert cli.main(argv) == 0
    rows = pq.read_table(out / 'batch.parquet').to_pylist()
    assert len(rows) == 3
    delay = next(r for r in rows if r['record'].endswith('delay_00.csv'))
    doc = json.loads((out / 'records' / batch.record_key(delay['record']) /
                      'result.json').read_text())
    # round 1 names delay; round 2 starts from the model with delay and names nothing more
    assert [r['named'] for r in doc['rounds']] == ['delay', None]
    assert doc['rounds'][1]['effects'] == ['delay']
    assert doc['rounds'][1]['validation_nrmse'] < doc['rounds'][0]['validation_nrmse']
    index = (out / 'index.html').read_text()
    for r in rows:
        assert (out / r['report']).is_file()
        assert r['report'] in index


def test_records_are_found_in_files_directories_and_globs(fleet):
    root, truth = fleet
    found = batch.find_records([str(root)])
    assert {p.name for p in found} == set(truth)
    globbed = batch.find_records([str(root / 'delay_0*.csv'), str(root / 'bags')])
    assert {p.name for p in globbed} == {f'delay_{i:02d}.csv' for i in range(N_DELAY)} | {
        'delay_bag', 'corrupt_bag'}
    assert len(batch.find_records([str(root / 'none_00.csv')] * 2)) == 1


def _exit_code(argv):
    """cli.main's exit code, also for argparse errors (which exit through SystemExit)."""
    try:
        return cli.main(argv)
    except SystemExit as stop:
        return stop.code


def test_missing_data_and_bad_options_are_one_line_errors(fleet, tmp_path, capsys):
    root, _ = fleet
    for argv in (['batch', str(tmp_path / 'nothing*.csv'), '--out', str(tmp_path / 'o')],
                 ['batch', str(root), '--out', str(root / 'none_00.csv')],
                 ['batch', str(root), '--out', str(tmp_path / 'o'), '--rounds', '0'],
                 ['batch', str(root), '--out', str(tmp_path / 'o'), '--candidates', 'bogus'],
                 ['batch', str(root), '--out', str(tmp_path / 'o'), '--position-unit', 'ft'],
                 ['batch', str(root), '--out', str(tmp_path / 'o'), '--column', 'pos=pot'],
                 ['batch', str(root), '--out', str(tmp_path / 'o'), '--column', 'duty_a=p',
                  '--column', 'duty_b=P']):
        assert _exit_code(argv) == cli.EXIT_BAD_INPUT
        err = capsys.readouterr().err
        assert err.count('\n') == 1 and err.startswith('sma-model'), err
    assert not (tmp_path / 'o').exists()


def test_table_and_recurrence_from_results():
    results = [{'record': '/d/b.csv', 'effects_added': 'delay convection', 'error': None,
                'parameters': {'delay_s': 0.3}},
               {'record': '/d/a.csv', 'effects_added': 'delay', 'error': None,
                'parameters': {'tau_s': 2.0}},
               {'record': '/d/c.csv', 'effects_added': '', 'error': 'bad', 'parameters': {}}]
    rows = table_rows(results)
    assert [r['record'] for r in rows] == ['/d/a.csv', '/d/b.csv', '/d/c.csv']
    assert rows[0]['param.delay_s'] is None and rows[1]['param.delay_s'] == 0.3
    assert effect_recurrence(rows) == {'delay': ['/d/a.csv', '/d/b.csv'],
                                       'convection': ['/d/b.csv']}


@pytest.mark.slow
def test_a_fitted_model_is_compared_with_every_record(fleet, scheduler, tmp_path):
    root, _ = fleet
    model = tmp_path / 'delay.yaml'
    assert cli.main(['fit', str(root / 'delay_00.csv'), '--add', 'delay', '--out',
                     str(model)]) == 0
    out = tmp_path / 'out'
    assert cli.main(['batch', str(root / 'delay_00.csv'), str(root / 'none_00.csv'),
                     '--model', str(model), '--candidates', 'delay', '--no-reports',
                     '--out', str(out), '--scheduler', scheduler]) == 0
    rows = {_name(r['record']): r for r in pq.read_table(out / 'batch.parquet').to_pylist()}
    # the model fitted on delay_00 predicts its own record well, and misses the plant
    # without the delay by far more
    assert rows['delay_00.csv']['reference_nrmse'] < 0.02
    assert rows['none_00.csv']['reference_nrmse'] > 5 * rows['delay_00.csv']['reference_nrmse']
    assert rows['delay_00.csv']['base_effects'] == 'delay'


@pytest.mark.slow
def test_a_loggers_own_columns_unit_and_layout_are_read_as_fit_reads_them(scheduler, tmp_path):
    root = tmp_path / 'logs'
    root.mkdir()
    rec = _record('delay', 9)
    # the logger's own names: stamps in ms, a state text, the position in mm named nowhere
    # and duty_a logged only where it changes
    changes = np.r_[True, np.diff(rec['duty_a']) != 0]
    with open(root / 'logger.csv', 'w') as fh:
        fh.write('t_ms,pwm_a,pwm_b,pot,state\n')
        for t, da, db, pos, logged in zip(*(rec[c] for c in COLUMNS), changes):
            fh.write(f'{t * 1e3:.1f},{f"{da:.6g}" if logged else ""},{db:.6g},{pos:.6g},HEAT\n')
    reading = ['--column', 'time[ms]=t_ms', '--column', 'duty_a=PWM_A', '--column',
               'duty_b=pwm_b', '--column', 'position=pot', '--position-unit', 'mm']
    out = tmp_path / 'out'
    assert cli.main(['batch', str(root), '--out', str(out), '--candidates', 'delay',
                     '--no-reports', '--scheduler', scheduler] + reading) == 0
    row, = pq.read_table(out / 'batch.parquet').to_pylist()
    assert row['error'] is None and row['position_unit'] == 'mm'
    assert row['named_effect'] == 'delay' and 0.6 < row['param.delay_s'] < 1.0
    assert row['duration_s'] == pytest.approx(DURATION_S, abs=0.2)
    assert 'param.stroke_mm' in row and 'param.stroke_rad' not in row
    # what fit would print about the reading is the record's note
    held = np.count_nonzero(~changes)
    assert row['notes'].startswith(f'duty_a is empty or NaN on {held} row(s)'), row['notes']
    assert str(root) not in row['notes']

    # a record that names no unit takes the unit of the fitted model it is compared with
    model = tmp_path / 'mm.yaml'
    assert cli.main(['fit', str(root / 'logger.csv'), '--add', 'delay', '--out', str(model)]
                    + reading) == 0
    plain = _record('delay', 10)
    _write_csv(root / 'plain.csv', plain)
    rad = _record('delay', 11)
    np.savetxt(root / 'in_rad.csv', np.column_stack([rad[c] for c in COLUMNS]), delimiter=',',
               header='time,duty_a,duty_b,position[rad]', comments='', fmt='%.6g')
    np.savetxt(root / 'in_um.csv', np.column_stack([plain[c] for c in COLUMNS]) * [1, 1, 1, 1e3],
               delimiter=',', header='time,duty_a,duty_b,position[um]', comments='', fmt='%.9g')
    out = tmp_path / 'compared'
    assert cli.main(['batch', str(root / 'plain.csv'), str(root / 'in_rad.csv'),
                     str(root / 'in_um.csv'), '--out', str(out), '--model', str(model),
                     '--candidates', 'delay', '--no-reports', '--scheduler', scheduler]) == 0
    rows = {_name(r['record']): r for r in pq.read_table(out / 'batch.parquet').to_pylist()}
    assert rows['plain.csv']['position_unit'] == 'mm'
    assert rows['plain.csv']['reference_nrmse'] < 0.02 and rows['plain.csv']['notes'] is None
    # the same record in um is compared in the model's mm, as compare converts it
    assert rows['in_um.csv']['position_unit'] == 'um'
    assert rows['in_um.csv']['reference_nrmse'] == pytest.approx(
        rows['plain.csv']['reference_nrmse'], rel=1e-6)
    # a record of another unit is not compared with the model (no NRMSE across units)
    assert rows['in_rad.csv']['position_unit'] == 'rad'
    assert rows['in_rad.csv']['reference_nrmse'] is None
    assert rows['in_rad.csv']['error'] is None

    # --layout single on records that heat wire b: each is an error row, in one line
    out = tmp_path / 'single'
    assert cli.main(['batch', str(root / 'plain.csv'), '--layout', 'single', '--out', str(out),
                     '--candidates', 'delay', '--no-reports', '--scheduler', scheduler]) == 0
    row, = pq.read_table(out / 'batch.parquet').to_pylist()
    assert '--layout single, but duty_b is used' in row['error']


def test_a_records_glitches_are_bridged_as_fit_bridges_them_unless_kept(tmp_path):
    rec = _record('none', 5)
    rec['position'][400] += 3.0   # rad: one sample far off
    path = str(tmp_path / 'glitch.csv')
    _write_csv(path, rec)
    data, notes = batch._read(path, batch.BatchOptions().reading(), 'stamp')
    assert not data.scored_mask()[400] and data.scored_mask().sum() == len(data) - 1
    assert len(notes) == 1 and notes[0].startswith('1 position sample(s) (the first at 40.000 s)')
    data, notes = batch._read(path, batch.BatchOptions(keep_glitches=True).reading(), 'stamp')
    assert data.scored is None and notes == ()
    assert data.position[400] == pytest.approx(rec['position'][400], abs=1e-5)


def _dead_time_row(tmp_path, *options):
    """Return the row of `batch` on a record with a PWM dead time of 0.2, with `options`."""
    _write_csv(tmp_path / 'dead.csv', _record('none', 12, dead_duty=0.2))
    out = tmp_path / 'out'
    # a cluster of its own: what its workers registered stays registered in them
    assert cli.main(['batch', str(tmp_path / 'dead.csv'), '--out', str(out), *options,
                     '--candidates', 'pwm_dead_time', 'delay', '--no-reports',
                     '--workers', '1']) == 0
    row, = pq.read_table(out / 'batch.parquet').to_pylist()
    return row


@pytest.mark.slow
def test_a_plugin_effect_is_registered_on_the_workers_and_named(tmp_path, catalog_guard):
    plugin = tmp_path / 'dead_time.py'
    plugin.write_text(DEAD_TIME_PLUGIN)
    row = _dead_time_row(tmp_path, '--plugin', str(plugin))
    assert row['error'] is None and row['named_effect'] == 'pwm_dead_time'
    assert row['param.dead_duty'] == pytest.approx(0.2, abs=0.05)
    # another version of the plug-in is another option: the record is computed again
    before = batch.BatchOptions(plugins=batch.worker_plugins([str(plugin)]))
    plugin.write_text(DEAD_TIME_PLUGIN + '\n# edited\n')
    after = batch.BatchOptions(plugins=batch.worker_plugins([str(plugin)]))
    assert before.fingerprint() != after.fingerprint()
    assert before.plugins[0][0] == str(plugin.resolve())


@pytest.mark.slow
def test_an_installed_entry_point_effect_is_registered_on_the_workers_and_named(
        tmp_path, monkeypatch, catalog_guard):
    # an effect a package exposes under the entry-point group, with no --plugin: each
    # worker process registers it before its first fit, as the client does
    site = install_entry_point(tmp_path / 'site', 'ep_dead_time', {'dead': 'PwmDeadTime'})
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setenv('PYTHONPATH', os.pathsep.join(
        filter(None, [str(site), os.environ.get('PYTHONPATH')])))
    row = _dead_time_row(tmp_path)
    assert row['error'] is None and row['named_effect'] == 'pwm_dead_time'
    assert row['param.dead_duty'] == pytest.approx(0.2, abs=0.05)


def test_a_local_cluster_beside_another_takes_a_free_http_port_without_a_warning():
    # two batches on one machine: the second scheduler's HTTP server (no dashboard) finds
    # the default port held and takes another, and the user's terminal is not told so
    with socket.socket() as held:
        with contextlib.suppress(OSError):   # held already by another process
            held.bind(('', 8787))
            held.listen()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter('always')
            client = batch.start_client(workers=1)
            client.close()
            client.cluster.close()
    assert [str(w.message) for w in caught if 'in use' in str(w.message)] == []


def test_a_plugin_a_worker_cannot_load_is_that_records_one_line_error(tmp_path):
    gone = tmp_path / 'gone.py'   # a file the client read, missing on the worker
    with pytest.raises(ValueError) as err:
        batch.register_effects(batch.worker_plugins([str(gone)]))
    assert batch.error_line(err.value) == f'plugin {gone}: no such file'


def test_reading_options_enter_the_fingerprint_only_when_set():
    # results written before the reading options existed resume: their fingerprint is kept
    assert batch.BatchOptions().fingerprint() == '02c4a91c80f9'
    assert batch.BatchOptions(effects=('delay',), rounds=2,
                              reference={'a': 1}).fingerprint() == 'b27508fdbac1'
    changed = [batch.BatchOptions(position_unit='mm'), batch.BatchOptions(layout='single'),
               batch.BatchOptions(default_unit='mm'),
               batch.BatchOptions(columns=('position=pot',)),
               batch.BatchOptions(keep_glitches=True)]
    prints = {o.fingerprint() for o in changed} | {batch.BatchOptions().fingerprint()}
    assert len(prints) == len(changed) + 1
