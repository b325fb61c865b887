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

"""CSV files as loggers and tools lay them out: code pages, numpy.savetxt, units rows, names."""
from datetime import datetime, timedelta

import numpy as np
import pytest
from sma_actuator.workbench.data import DataError, load_data, parse_column_map

NAMES = ('time', 'duty_a', 'duty_b', 'position', 'ambient_temperature')


def _rows(n=40, dt=0.05):
    """Return the columns of `NAMES`: a record of n samples every dt [s]."""
    t = np.arange(n) * dt
    return np.column_stack([t, 0.5 + 0.4 * np.sin(t), 0.5 - 0.4 * np.sin(t),
                            3.0 * np.sin(t - 0.2), 22.0 + 0.01 * t])


def _table(header, rows, sep=',', comments=(), under=()):
    """Return CSV text: comment lines, a header row, rows under it, then the numbers."""
    lines = [*comments, header, *under]
    lines += [sep.join(f'{v:.6g}' for v in row) for row in rows]
    return '\n'.join(lines) + '\n'


def _reference(tmp_path):
    """Return the plain UTF-8 comma-separated record in mm that every layout must equal."""
    path = tmp_path / 'plain.csv'
    path.write_text(_table(','.join(NAMES), _rows()))
    return load_data(path, position_unit='mm')


def _assert_same(data, reference, time_from=0.0):
    """Assert that `data` is `reference`, its time counted from `time_from` [s]."""
    np.testing.assert_allclose(data.time - time_from, reference.time, atol=1e-6)
    for name in ('duty_a', 'duty_b', 'position', 'ambient'):
        np.testing.assert_allclose(getattr(data, name), getattr(reference, name), atol=1e-9,
                                   err_msg=name)
    assert data.position_unit == reference.position_unit


@pytest.mark.parametrize('encoding', ['cp1252', 'utf-16'])
def test_a_windows_code_page_and_utf16_read_as_utf8_does(tmp_path, encoding):
    # '°' and 'µ' are single bytes in code page 1252 and every second byte is NUL in UTF-16
    text = _table('time,duty_a,duty_b,position,ambient_temperature[°C]', _rows(),
                  comments=['# bench 3, ambient 22 °C, position in µm'])
    (tmp_path / 'utf8.csv').write_text(text, encoding='utf-8')
    (tmp_path / 'other.csv').write_bytes(text.encode(encoding))
    utf8 = load_data(tmp_path / 'utf8.csv')
    assert utf8.position_unit == 'um'
    _assert_same(load_data(tmp_path / 'other.csv'), utf8)


@pytest.mark.parametrize('head, kind', [
    (b'MATLAB 5.0 MAT-file, Platform: GLNXA64\x00\x00\x01IM', r'a MATLAB \.mat file'),
    (b'PK\x03\x04\x14\x00\x06\x00', r'a zip archive: an \.xlsx workbook\? save the sheet as CSV'),
    (b'SQLite format 3\x00\x10\x00', r'an SQLite file: a rosbag2 \.db3 bag\? convert it to MCAP'),
    (b'\x7fELF\x02\x01\x01\x00', r'it holds binary data'),
])
def test_binary_data_is_no_csv_and_the_error_says_what_it_seems_to_be(tmp_path, head, kind):
    (tmp_path / 'rec.csv').write_bytes(head + bytes(range(256)))
    with pytest.raises(DataError, match=f'rec.csv: not a text CSV file \\({kind}'):
        load_data(tmp_path / 'rec.csv')


@pytest.mark.parametrize('sep', [',', ' ', '\t'])
def test_a_numpy_savetxt_file_reads_its_header_from_its_comment(tmp_path, sep):
    path = tmp_path / 'saved.csv'
    np.savetxt(path, _rows(), fmt='%.6g', delimiter=sep, header=sep.join(NAMES),
               comments='# position in mm\n# ')
    assert path.read_text().splitlines()[1].startswith('# time')
    _assert_same(load_data(path), _reference(tmp_path))


def test_a_comment_that_names_no_columns_stays_a_comment(tmp_path):
    path = tmp_path / 'bare.csv'
    path.write_text(_table('0,0.5,0.5,0,22', _rows(), comments=['# run 3, 100 Hz, not tared']))
    with pytest.raises(DataError, match='line 2: the first row holds numbers'):
        load_data(path)


def test_a_row_of_units_under_the_header_scales_and_names_the_columns(tmp_path):
    rows = _rows() * [1000, 100, 100, 1, 1]
    path = tmp_path / 'daq.csv'
    path.write_text(_table(','.join(NAMES), rows, under=['ms,%,[%],(mm),°C']))
    _assert_same(load_data(path), _reference(tmp_path))
    # a unit of its own in the name stays; the dimensionless 1 is a unit too
    path.write_text(_table('time[s],duty_a,duty_b,position,ambient_temperature', _rows(),
                           under=['ms,1,-,mm,']))
    _assert_same(load_data(path), _reference(tmp_path))


def test_a_row_of_units_the_reader_does_not_know_is_a_one_line_error(tmp_path):
    path = tmp_path / 'daq.csv'
    path.write_text(_table(','.join(NAMES), _rows(), under=['s,-,-,furlong,°C']))
    with pytest.raises(DataError, match="unknown position unit 'furlong'"):
        load_data(path)
    path.write_text(_table(','.join(NAMES), _rows(), under=['s,0.5,-,mm,°C']))
    with pytest.raises(DataError, match="line 2, column 'time': 's' is not a number"):
        load_data(path)


def test_a_static_curve_with_a_row_of_units_reads_as_without(tmp_path):
    v = np.linspace(0, 5, 20)
    curve = np.column_stack([np.zeros_like(v), v, 0.1 * v * v])
    (tmp_path / 'plain.csv').write_text(_table('curve,voltage,deflection', curve))
    (tmp_path / 'units.csv').write_text(_table('curve,voltage,deflection', curve,
                                               under=['-,V,mm']))
    plain, units = load_data(tmp_path / 'plain.csv'), load_data(tmp_path / 'units.csv')
    np.testing.assert_array_equal(units.input, plain.input)
    np.testing.assert_array_equal(units.output, plain.output)


@pytest.mark.parametrize('header, sep', [
    ('Time (s),Duty A,Duty B,Position (mm),Ambient Temperature', ','),
    ('time (s)\tDuty  A\tduty_b\tposition [mm]\tambient_temperature', '\t'),
    ('time (s) duty_a duty_b position [mm] ambient_temperature [°C]', ' '),
])
def test_column_names_with_spaces_and_units_apart_from_them(tmp_path, header, sep):
    path = tmp_path / 'names.csv'
    path.write_text(_table(header, _rows(), sep=sep))
    _assert_same(load_data(path), _reference(tmp_path))


def test_a_column_map_names_a_column_with_spaces_as_written(tmp_path):
    path = tmp_path / 'own.csv'
    path.write_text(_table('time,duty_a,duty_b,Pot Value,ambient_temperature', _rows()))
    renames = parse_column_map(['position[mm]=Pot Value'])
    _assert_same(load_data(path, renames=renames), _reference(tmp_path))


START = datetime(2026, 12, 4, 23, 59, 59, 120000)   # the record passes midnight
CLOCKS = {
    'date T time': (lambda t: (START + timedelta(seconds=t)).isoformat(), START.timestamp()),
    'date time, zone': (lambda t: (START + timedelta(seconds=t)).isoformat(
        sep=' ', timespec='milliseconds') + '+01:00', START.timestamp() - 3600),
    'time of day': (lambda t: (START + timedelta(seconds=t)).time().isoformat(
        timespec='milliseconds'), 86399.12),
}


def _clock_table(stamp, rows):
    lines = [','.join(NAMES)] + [','.join([stamp(row[0]), *(f'{v:.6g}' for v in row[1:])])
                                 for row in rows]
    return '\n'.join(lines) + '\n'


@pytest.mark.parametrize('clock', CLOCKS, ids=list(CLOCKS))
def test_a_time_column_of_clock_times_reads_as_seconds_with_a_note(tmp_path, clock):
    stamp, start_s = CLOCKS[clock]
    path = tmp_path / 'stamped.csv'
    path.write_text(_clock_table(stamp, _rows()))
    notes = []
    data = load_data(path, position_unit='mm', notes=notes)
    _assert_same(data, _reference(tmp_path), time_from=start_s)
    assert notes == [f"{path}: column 'time' holds clock times (the first {stamp(0.0)}): "
                     'read as seconds from it']


def test_a_clock_time_column_with_a_stamp_it_cannot_read_names_the_line(tmp_path):
    stamp = CLOCKS['date T time'][0]
    path = tmp_path / 'stamped.csv'
    lines = _clock_table(stamp, _rows()).splitlines()
    lines[5] = lines[5].replace('T', ' at ', 1)
    path.write_text('\n'.join(lines) + '\n')
    with pytest.raises(DataError, match="line 6, column 'time': .* is not a clock time"):
        load_data(path)
