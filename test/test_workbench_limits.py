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

"""Workbench input limits (issue 13 item 7): strict numbers, period, size, rows, progress."""
import contextlib
import io

import pytest

from sma_actuator.workbench import cli, csv_table, data, limits


def _csv(path, rows, step=0.01, first='0'):
    lines = ['time,duty_a,duty_b,position', f'{first},0.5,0.1,0.0']
    lines += [f'{k * step!r},{0.5 + 0.4 * (k % 2)},0.1,{0.01 * (k % 5)}' for k in range(1, rows)]
    path.write_text('\n'.join(lines) + '\n')
    return path


def _main(argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = cli.main(argv)
        except SystemExit as stop:
            code = stop.code
    return code, err.getvalue().splitlines()


@pytest.mark.parametrize('text', ['١', '１', '1_0', '٠.٥', '１e3', ' 1 0'])
def test_numbers_outside_ascii_decimals_are_rejected(tmp_path, text):
    path = _csv(tmp_path / 'x.csv', 20, first=text)
    with pytest.raises(data.DataError, match='line 2, column .time.: .* is not a number'):
        data.load_data(path)


@pytest.mark.parametrize('step', [1e-300, 1e-5, 20.0, 1e300])
def test_a_sample_period_outside_the_limits_is_one_line(tmp_path, step):
    path = _csv(tmp_path / 'x.csv', 20, step=step)
    code, lines = _main(['fit', str(path)])
    assert code == 2 and len(lines) == 1 and 'sample period' in lines[0], lines


@pytest.mark.parametrize('step', [1, 5, 10])
def test_a_time_column_counting_whole_numbers_without_a_unit_must_name_it(tmp_path, step):
    # a logger's millis() at 1 kHz to 100 Hz read as seconds is a 1 to 0.1 Hz record, and a
    # fit of it ends at the time constant's bound: the unit is asked for, not guessed
    path = _csv(tmp_path / 'x.csv', 20, step=step)
    code, lines = _main(['fit', str(path)])
    assert code == 2 and len(lines) == 1, lines
    assert f"column 'time' counts whole numbers {step} apart: " in lines[0]
    assert 'time[ms] or time[s]' in lines[0]
    renamed = data.load_data(path, renames=data.parse_column_map(['time[ms]=time']))
    assert renamed.dt == pytest.approx(step / 1000)
    named = path.read_text().replace('time,', 'time[s],', 1)
    assert data.load_data(_write(tmp_path / 's.csv', named)).dt == pytest.approx(step)
    # seconds that are not all whole numbers are seconds
    assert data.load_data(_csv(tmp_path / 'h.csv', 20, step=step - 0.5)).dt == step - 0.5


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize('rate', ['1e308', '1e-300', '5e4', '１'])
def test_rate_outside_the_limits_is_one_line(tmp_path, rate):
    code, lines = _main(['fit', str(_csv(tmp_path / 'x.csv', 20)), '--rate', rate])
    assert code == 2 and len(lines) == 1 and '--rate' in lines[0], lines


def test_a_quoted_field_over_128_kib_is_one_line(tmp_path):
    path = tmp_path / 'x.csv'
    path.write_text('time,duty_a,duty_b,position\n"' + 'x' * 140_000 + '",0,0,0\n')
    code, lines = _main(['fit', str(path)])
    assert code == 2 and len(lines) == 1 and 'line 2: not a valid CSV row' in lines[0], lines


def test_rows_and_bytes_beyond_the_limits_are_one_line(tmp_path, monkeypatch):
    path = _csv(tmp_path / 'x.csv', 50)
    monkeypatch.setattr(limits, 'MAX_ROWS', 40)
    code, lines = _main(['fit', str(path)])
    assert code == 2 and len(lines) == 1 and 'over the limit of 40 rows' in lines[0]
    monkeypatch.setattr(limits, 'MAX_CSV_BYTES', 100)
    code, lines = _main(['fit', str(path)])
    assert code == 2 and len(lines) == 1 and 'over the limit of 100 bytes' in lines[0]


def test_a_large_csv_logs_its_progress_without_a_terminal(tmp_path):
    path = _csv(tmp_path / 'big.csv', limits.PROGRESS_MIN_ROWS)
    err = io.StringIO()  # not a terminal
    with contextlib.redirect_stderr(err):
        header, rows, _ = csv_table.read_csv_table(path)
    lines = err.getvalue().splitlines()
    assert len(rows) == limits.PROGRESS_MIN_ROWS
    assert [line.split(': ')[2].split(' %')[0] for line in lines] == [
        str(p) for p in range(10, 101, 10)]
    assert lines[-1].startswith('sma-model: reading big.csv: 100 % (100000 of 100000 rows, ')
    assert lines[-1].endswith(' s)')
