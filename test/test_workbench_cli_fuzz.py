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
`sma-model` fuzz: malformed CSVs, bags and options exit 0 with valid data or 2 with one line.

Issue 13 item 7. Cases run in process through ``cli.main`` with the model fit replaced by a
stub that keeps the loaded data (the fit itself is tested elsewhere; here the question is what
reaches it); a few run as real subprocesses to show that no traceback reaches stderr.
"""
import collections
import contextlib
import io
import os
import random
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from sma_actuator.workbench import cli, engine, limits
from support.bag_fuzz import make_sources, MCAP_KINDS, mutate_bag

SEED = 7013
CSV_CASES = int(os.environ.get('FUZZ_CASES', 1000))
BAG_CASES = max(1, CSV_CASES // 8)
NASTY = ('١', '１', '1_0', '١٫٥', '½', '²', 'nan', 'inf', '-inf', 'Infinity', '1e400', '',
         ' ', '0x10', '1,5', 'True', '\x00', '１e3', '+.5', '.', '-', 'e5', '1e', '--1',
         '"' + 'x' * 140_000 + '"', '1e-300', '1e300', '٣.٠', '1 0', '\u00a01', '0b1')
RATES = ('1e308', '1e-300', 'nan', '-1', '0', '١', '1_0', '5e4', '0.01', 'inf', '100')


def _dynamic_csv(rows=60):
    """Return a valid dynamic record (time [s], duties, position [rad])."""
    t = np.arange(rows) * 0.02
    duty_a = 0.5 + 0.4 * np.sin(2 * np.pi * 0.5 * t)
    position = 0.3 * np.sin(2 * np.pi * 0.5 * t - 0.3)
    lines = ['# made-up record', 'time,duty_a,duty_b,position']
    lines += [f'{a:.4f},{b:.6f},{1 - b:.6f},{p:.6f}' for a, b, p in
              zip(t, duty_a, position)]
    return '\n'.join(lines) + '\n'


def _static_csv():
    lines = ['curve,voltage,deflection']
    for curve in range(2):
        lines += [f'{curve},{v:.2f},{0.1 * v * v:.4f}' for v in np.linspace(0, 5, 20)]
    return '\n'.join(lines) + '\n'


def _mutate_csv(rng, text):
    """Return (bytes, description) of one mutation of a CSV text."""
    lines = text.split('\n')
    kind = rng.randrange(9)
    if kind == 0:  # a field replaced by a nasty token
        k = rng.randrange(1, len(lines) - 1)
        fields = lines[k].split(',')
        token = rng.choice(NASTY)
        fields[rng.randrange(len(fields))] = token
        lines[k] = ','.join(fields)
        return '\n'.join(lines).encode(), f'line {k + 1}: field {token[:12]!r}'
    if kind == 1:  # a time step of 1e-300 or 1e300 s
        step = rng.choice((1e-300, 1e300, 1e-5, 20.0, 0.0))
        out = lines[:2] + [f'{i * step!r},' + ','.join(line.split(',')[1:])
                           for i, line in enumerate(lines[2:-1])] + ['']
        return '\n'.join(out).encode(), f'time step {step} s'
    raw = bytearray(text.encode())
    if kind == 2:
        for _ in range(rng.choice((1, 2, 4))):
            raw[rng.randrange(len(raw))] ^= 1 << rng.randrange(8)
        return bytes(raw), 'bit flips'
    if kind == 3:
        cut = rng.randrange(len(raw))
        return bytes(raw[:cut]), f'cut at {cut}'
    if kind == 4:
        start = rng.randrange(len(raw))
        raw[start:start + rng.choice((1, 8, 64))] = bytes(8)
        return bytes(raw), f'NUL bytes at {start}'
    if kind == 5:  # header damage
        header = rng.choice(('time,time,duty_b,position', 'time,duty_a,duty_b', ',duty_a,x,y',
                             '1,2,3,4', 'time;duty_a;duty_b;position', '\ufefftime,duty_a,'
                             'duty_b,position', 'TIME,Duty_A,duty_b,position,extra'))
        lines[1] = header
        return '\n'.join(lines).encode(), f'header {header!r}'
    if kind == 6:  # encodings
        enc = rng.choice(('utf-16', 'latin-1', 'utf-8-sig'))
        return (text.replace('made-up', 'mäde-üp').encode(enc)), f'encoded {enc}'
    if kind == 7:  # rows shuffled or repeated
        body = lines[2:-1]
        k = rng.randrange(len(body))
        body.insert(rng.randrange(len(body)), body[k])
        return '\n'.join(lines[:2] + body + ['']).encode(), f'row {k} repeated'
    token = rng.choice(('\r', '"', '\x0b', '\u2028', ',,', '#'))
    pos = rng.randrange(len(raw))
    return bytes(raw[:pos]) + token.encode() + bytes(raw[pos:]), f'{token!r} inserted'


def _run(argv):
    """Run cli.main in process; return (exit code, stdout, stderr, exception or None)."""
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = cli.main(argv)
    except SystemExit as stop:
        code = stop.code
    except Exception as exc:  # noqa: BLE001 - an escaping exception is what the fuzz looks for
        return None, out.getvalue(), err.getvalue(), exc
    return code, out.getvalue(), err.getvalue(), None


def _data_problem(data):
    """Return what is wrong with data that reached the fit, or None."""
    if not hasattr(data, 'time'):
        ok = all(np.all(np.isfinite(v)) for v in (data.input, data.output))
        return None if ok else 'non-finite static data'
    steps = np.diff(data.time)
    if not (np.all(np.isfinite(data.time)) and np.all(steps > 0)):
        return 'time not finite and increasing'
    if limits.period_problem(float(np.median(steps))):
        return f'period {np.median(steps):g} s outside the limits'
    for name in ('duty_a', 'duty_b', 'position'):
        values = getattr(data, name)
        if not np.all(np.isfinite(values)):
            return f'{name} not finite'
    if np.any((data.duty_a < 0) | (data.duty_a > 1) | (data.duty_b < 0) | (data.duty_b > 1)):
        return 'duty outside [0, 1]'
    return None


@pytest.fixture
def stub_fit(monkeypatch):
    """Replace the model fit by a stub that keeps the data it is given (and predicts it)."""
    seen = []

    def fake_fit(data, effects=(), kind=None, progress=None, **_):
        seen.append(data)
        return SimpleNamespace(effects=tuple(effects), kind=kind or 'modified', n_parameters=0,
                               values={}, train=None, validation=None, signals={},
                               prediction=getattr(data, 'position', None), split=None,
                               to_dict=lambda: {}, simulate=lambda other: other.position)
    monkeypatch.setattr(engine, 'fit_model', fake_fit)
    return seen


def _classify(argv, seen):
    before = len(seen)
    code, _, err, exc = _run(argv)
    lines = err.splitlines()
    if exc is not None:
        return 'failure', f'{type(exc).__name__}: {str(exc)[:200]}'
    if code == 0:
        if len(seen) != before + 1:
            return 'failure', 'exit 0 without data reaching the fit'
        problem = _data_problem(seen[-1])
        return ('failure', f'exit 0 with bad data: {problem}') if problem else ('ok', '')
    if code == cli.EXIT_BAD_INPUT and len(lines) == 1 and lines[0].startswith(
            'sma-model: error: '):
        return 'error', ''
    return 'failure', f'exit {code}, stderr {err[:300]!r}'


@pytest.mark.slow
def test_malformed_inputs_exit_0_with_valid_data_or_2_with_one_line(tmp_path, stub_fit):
    rng = random.Random(SEED)
    outcomes = collections.Counter()
    failures = []
    bases = {'dynamic': _dynamic_csv(), 'static': _static_csv()}
    for case in range(CSV_CASES):
        base = 'static' if case % 5 == 4 else 'dynamic'
        data, what = _mutate_csv(rng, bases[base])
        path = tmp_path / f'case{case % 7}.csv'
        path.write_bytes(data)
        argv = ['fit', str(path)]
        if case % 10 == 3:
            argv += ['--rate', rng.choice(RATES)]
        outcome, detail = _classify(argv, stub_fit)
        outcomes[outcome] += 1
        if outcome == 'failure':
            failures.append(f'csv case {case} ({base}, {what}, {argv[2:]}): {detail}')
    sources = make_sources(tmp_path / 'bags')
    names = sorted(sources)
    kinds = MCAP_KINDS + ('metadata',)
    for case in range(BAG_CASES):
        name = names[case % len(names)]
        kind = kinds[rng.randrange(len(kinds))]
        target = tmp_path / 'bagcase' / name
        other = sources[names[(case + 1) % len(names)]]
        what = mutate_bag(rng, sources[name], target, other, kind)
        argv = ['fit', str(target)] + (['--rate', rng.choice(RATES)] if case % 4 == 1 else [])
        outcome, detail = _classify(argv, stub_fit)
        outcomes[outcome] += 1
        if outcome == 'failure':
            failures.append(f'bag case {case} ({name}, {what}, {argv[2:]}): {detail}')
    total = CSV_CASES + BAG_CASES
    summary = (f'{total} malformed inputs ({CSV_CASES} CSV, {BAG_CASES} bags): exit 0 with '
               f'valid data {outcomes["ok"]}, exit 2 with one line {outcomes["error"]}, '
               f'failures {outcomes["failure"]}')
    print(summary)
    for line in failures[:40]:
        print('  ' + line[:300])
    assert not failures, summary + '\n' + '\n'.join(f[:300] for f in failures[:15])


@pytest.mark.slow
def test_one_line_error_reaches_stderr_of_a_real_process(tmp_path):
    """A handful of inputs that raised tracebacks before, through a real `sma-model` process."""
    good = _dynamic_csv()
    cases = {
        'quoted_field.csv': good.replace('0.0200,', '"' + 'x' * 140_000 + '",', 1),
        'arabic.csv': good.replace('0.0200,', '٠.٠٢,', 1),
        'fullwidth.csv': good.replace('0.0200,', '０.０２,', 1),
        'underscore.csv': good.replace('0.0200,', '0.0_2,', 1),
    }
    steps = '\n'.join(f'{i * 1e-300!r},0.5,0.5,{0.01 * (i % 7)}' for i in range(30))
    cases['step_1e-300.csv'] = 'time,duty_a,duty_b,position\n' + steps + '\n'
    steps = '\n'.join(f'{i * 1e300!r},0.5,0.5,{0.01 * (i % 7)}' for i in range(30))
    cases['step_1e300.csv'] = 'time,duty_a,duty_b,position\n' + steps + '\n'
    for name, text in cases.items():
        (tmp_path / name).write_text(text, encoding='utf-8')
    corrupt = tmp_path / 'corrupt.mcap'
    corrupt.write_bytes(b'\x89MCAP0\r\n' + bytes(range(256)) * 4)
    runs = [[str(tmp_path / name)] for name in cases] + [[str(corrupt)],
                                                         [str(tmp_path / 'arabic.csv'),
                                                          '--rate', '1e308']]
    for args in runs:
        proc = subprocess.run([sys.executable, '-m', 'sma_actuator.workbench.cli', 'fit', *args],
                              capture_output=True, text=True, timeout=120)
        lines = proc.stderr.splitlines()
        assert proc.returncode == 2 and len(lines) == 1, (args[1:], proc.stderr[-2000:])
        assert lines[0].startswith('sma-model: error: ') and 'Traceback' not in proc.stderr
