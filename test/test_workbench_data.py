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

"""Workbench DATA loading: CSV (dynamic, static), MCAP bags, and clear errors on bad input."""
from dataclasses import replace
import json
from pathlib import Path
import warnings

from conftest import real_data_path
import numpy as np
import pytest
from sma_actuator.core.identification import DynamicData
from sma_actuator.workbench.data import (check_excitation, DataError, describe, load_data,
                                         parse_column_map)
from sma_actuator.workbench.units import in_unit, unit_factor
from support.csv_edit import edit_positions, shifted

REAL = real_data_path()


def _dynamic_rows(n=40, dt=0.05):
    t = np.arange(n) * dt
    da = 0.5 + 0.4 * np.sin(t)
    db = 0.5 - 0.4 * np.sin(t)
    pos = 0.3 * np.sin(t - 0.2)
    return t, da, db, pos


def _write(path, header, rows, comments=()):
    lines = list(comments) + [header] + [','.join(f'{v:.6g}' for v in r) for r in rows]
    path.write_text('\n'.join(lines) + '\n')
    return path


@pytest.fixture
def dynamic_csv(tmp_path):
    t, da, db, pos = _dynamic_rows()
    amb = 22.0 + 0.01 * t
    return _write(tmp_path / 'run.csv', 'time,duty_a,duty_b,position,ambient_temperature',
                  np.column_stack([t, da, db, pos, amb]), comments=['# made-up run', ''])


def _lines(path):
    return path.read_text().splitlines()


def _rewrite(path, lines):
    path.write_text('\n'.join(lines) + '\n')
    return path


def test_dynamic_csv_loads_values_and_optional_ambient(dynamic_csv):
    data = load_data(dynamic_csv)
    t, da, db, pos = _dynamic_rows()
    assert isinstance(data, DynamicData) and data.kind == 'dynamic'
    np.testing.assert_allclose(data.time, t, atol=1e-9)
    np.testing.assert_allclose(data.duty_b, db, atol=1e-6)
    np.testing.assert_allclose(data.position, pos, atol=1e-6)
    np.testing.assert_allclose(data.ambient, 22.0 + 0.01 * t, atol=1e-6)
    assert data.setpoint is None
    assert '40 samples at 20 Hz' in describe(data)


def test_column_order_case_and_extra_columns_do_not_matter(tmp_path):
    t, da, db, pos = _dynamic_rows()
    path = _write(tmp_path / 'x.csv', 'Position, TIME ,duty_b,note,duty_a,setpoint',
                  np.column_stack([pos, t, db, np.ones_like(t), da, pos + 0.1]))
    data = load_data(path)
    np.testing.assert_allclose(data.duty_a, da, atol=1e-6)
    np.testing.assert_allclose(data.setpoint, pos + 0.1, atol=1e-6)
    assert data.ambient is None


@pytest.mark.parametrize('case', ['jitter', 'rounded', 'dropped'])
def test_an_unsteady_clock_is_resampled_with_a_note(tmp_path, case):
    """Host-clock jitter, stamps rounded to 10 ms at 40 Hz, one dropped sample."""
    n, dt = 400, 0.025
    t = np.arange(n) * dt
    duty = np.where((t // 2.0) % 2 == 1, 0.6, 0.1)
    jitter = np.r_[0.0, np.random.default_rng(0).uniform(-0.006, 0.006, n - 2), 0.0]
    stamps = {'jitter': t + jitter, 'rounded': np.round(t, 2), 'dropped': t}[case]
    keep = np.arange(n) != 200 if case == 'dropped' else np.ones(n, bool)
    path = _write(tmp_path / 'u.csv', 'time,duty_a,position',
                  np.column_stack([stamps, duty, 0.3 * np.sin(0.7 * stamps)])[keep])
    notes = []
    data = load_data(path, notes=notes)
    assert len(notes) == 1 and 'resampled to a steady' in notes[0], notes
    # the mean step: a dropped sample of 400 lengthens it by 1/398
    assert data.dt == pytest.approx(dt, rel=3e-3)
    # the position interpolated at the new times, each duty the one in effect there
    np.testing.assert_allclose(data.position, 0.3 * np.sin(0.7 * data.time), atol=2e-3)
    assert set(np.unique(data.duty_a)) == {0.1, 0.6}       # held, never interpolated
    in_effect = duty[np.searchsorted(t, data.time + 0.5 * dt) - 1]
    assert np.mean(data.duty_a == in_effect) > 0.97


def test_a_steady_record_is_not_touched(dynamic_csv):
    notes = []
    data = load_data(dynamic_csv, notes=notes)
    assert notes == []
    np.testing.assert_array_equal(data.time, [float(f'{v:.6g}') for v in np.arange(40) * 0.05])


@pytest.mark.parametrize('header,sep,scale', [('time[ms],duty_a,position', ',', 1e3),
                                              ('time (s);duty_a;position', ';', 1.0),
                                              ('time\tduty_a\tposition', '\t', 1.0)])
def test_time_unit_and_separator_come_from_the_header(tmp_path, header, sep, scale):
    t, da, _, pos = _dynamic_rows()
    lines = [header] + [sep.join(f'{v:.6g}' for v in r)
                        for r in np.column_stack([t * scale, da, pos])]
    path = tmp_path / 'x.csv'
    path.write_text('\n'.join(lines) + '\n')
    data = load_data(path)
    np.testing.assert_allclose(data.time, t, atol=1e-9)
    np.testing.assert_allclose(data.position, pos, atol=1e-6)


@pytest.mark.parametrize('sep', [';', '\t'])
def test_a_spreadsheet_with_decimal_commas_beside_another_separator_reads_as_points(
        tmp_path, sep):
    # a spreadsheet of a locale whose decimal mark is the comma separates fields with ';'
    t, da, db, pos = _dynamic_rows()
    rows = np.column_stack([t, da, db, pos])
    points = _write(tmp_path / 'points.csv', 'time,duty_a,duty_b,position', rows)
    lines = [sep.join(['time', 'duty_a', 'duty_b', 'position[mm]'])]
    lines += [sep.join(f'{v:.6g}'.replace('.', ',') for v in r) for r in rows]
    commas = tmp_path / 'commas.csv'
    commas.write_text('\n'.join(lines) + '\n')
    assert any(',' in line for line in lines[1:])
    data, want = load_data(commas), load_data(points)
    for name in ('time', 'duty_a', 'duty_b', 'position'):
        np.testing.assert_array_equal(getattr(data, name), getattr(want, name))
    assert data.position_unit == 'mm'
    # a comma beside a point is no decimal mark: the field is no number
    commas.write_text(commas.read_text().replace(lines[2], lines[2].replace(',', '.,', 1)))
    with pytest.raises(DataError, match=r"line 3, column 'time': '0\.,05' is not a number"):
        load_data(commas)


def test_an_unknown_time_unit_is_a_data_error(tmp_path):
    t, da, _, pos = _dynamic_rows()
    path = _write(tmp_path / 'x.csv', 'time[min],duty_a,position', np.column_stack([t, da, pos]))
    with pytest.raises(DataError, match=r"unknown time unit 'min'; known: s, sec, ms, us"):
        load_data(path)


@pytest.mark.parametrize('header,time_scale,duty_scale,unit', [
    ('time_ms,duty_a[%],position_mm', 1e3, 100.0, 'mm'),
    ('time [s],duty_a (%),position (mm)', 1.0, 100.0, 'mm'),
    ('time,duty_a[-],position[°]', 1.0, 1.0, 'deg')])
def test_units_of_time_duty_and_position_come_from_the_header(tmp_path, header, time_scale,
                                                              duty_scale, unit):
    t, da, _, pos = _dynamic_rows()
    path = _write(tmp_path / 'x.csv', header,
                  np.column_stack([t * time_scale, da * duty_scale, pos]))
    data = load_data(path)
    np.testing.assert_allclose(data.time, t, atol=1e-9)
    np.testing.assert_allclose(data.duty_a, da, atol=1e-6)
    assert data.position_unit == unit


def test_a_one_wire_record_may_call_its_duty_column_duty(tmp_path):
    t, da, _, pos = _dynamic_rows()
    path = _write(tmp_path / 'w.csv', 'time,duty[%],position[mm]',
                  np.column_stack([t, 100 * da, pos]))
    data = load_data(path)
    np.testing.assert_allclose(data.duty_a, da, atol=1e-6)
    assert data.layout == 'single' and not data.duty_b.any()
    # beside duty_b, a column named duty is not wire a's: it is an extra column
    path = _write(tmp_path / 'ab.csv', 'time,duty,duty_b,position',
                  np.column_stack([t, da, da, pos]))
    with pytest.raises(DataError, match=r'missing column\(s\) duty_a .*time,duty,position'):
        load_data(path)


def test_the_unit_a_record_names_is_told_from_the_default(tmp_path):
    t, da, db, pos = _dynamic_rows()
    rows = np.column_stack([t, da, db, pos])
    header = _write(tmp_path / 'h.csv', 'time,duty_a,duty_b,position[mm]', rows)
    comment = _write(tmp_path / 'c.csv', 'time,duty_a,duty_b,position', rows,
                     comments=['# position in deg, 100 Hz'])
    bare = _write(tmp_path / 'b.csv', 'time,duty_a,duty_b,position', rows)
    assert [load_data(p, default_unit='').position_unit for p in (header, comment, bare)] \
        == ['mm', 'deg', '']
    assert load_data(bare).position_unit == 'rad'   # read in the default unit


def test_units_of_one_quantity_convert_and_others_do_not(dynamic_csv):
    assert unit_factor('um', 'mm') == pytest.approx(1e-3)
    assert unit_factor('in', 'mm') == pytest.approx(25.4)
    assert unit_factor('deg', 'rad') == pytest.approx(np.pi / 180)
    assert unit_factor('mV', 'V') == pytest.approx(1e-3)
    assert unit_factor('mm', 'mm') == 1.0
    assert unit_factor('mm', 'deg') is None and unit_factor('counts', 'counts') == 1.0
    assert unit_factor('counts', 'mm') is None and unit_factor('%', 'mm') is None
    data = load_data(dynamic_csv, position_unit='m')
    data.setpoint = data.position + 0.1
    mm = in_unit(data, 'mm')
    assert mm.position_unit == 'mm' and data.position_unit == 'm'   # a copy
    np.testing.assert_allclose(mm.position, 1000 * data.position)
    np.testing.assert_allclose(mm.setpoint, 1000 * data.setpoint)
    assert in_unit(data, 'm') is data and in_unit(data, 'rad') is None


def test_an_unknown_duty_unit_and_a_percentage_without_its_unit_are_data_errors(tmp_path):
    t, da, _, pos = _dynamic_rows()
    path = _write(tmp_path / 'v.csv', 'time,duty_a[V],position', np.column_stack([t, da, pos]))
    with pytest.raises(DataError, match=r"unknown duty unit 'v'; known: -, 1, fraction, %"):
        load_data(path)
    path = _write(tmp_path / 'p.csv', 'time,duty_a,position',
                  np.column_stack([t, 100 * da, pos]))
    with pytest.raises(DataError, match=r'outside \[0, 1\] .*name its unit: duty_a\[%\] for a '
                                        r'percentage, duty_a\[1/255\] for counts of a PWM'):
        load_data(path)


@pytest.mark.parametrize('top', [255, 1023, 4095])
def test_a_duty_in_counts_of_a_pwm_timer_is_read_with_the_timers_top(tmp_path, top):
    # analogWrite(pin, 51) on an 8-bit timer is duty 0.2: the header says 1/255 per count
    t, da, db, pos = _dynamic_rows()
    counts = np.round(da * top)
    path = _write(tmp_path / 'c.csv', f'time,duty_a[1/{top}],duty_b,position',
                  np.column_stack([t, counts, db, pos]))
    np.testing.assert_allclose(load_data(path).duty_a, counts / top, rtol=1e-12)
    path = _write(tmp_path / 'o.csv', 'time,duty_a[1/0],duty_b,position',
                  np.column_stack([t, counts, db, pos]))
    with pytest.raises(DataError, match=r"unknown duty unit '1/0'; known: .*, 1/N \(counts "
                                        r'of a PWM timer whose top is N\)'):
        load_data(path)


def test_real_morphing_wing_curves_load_as_static_data():
    data = load_data(REAL)
    assert data.kind == 'static'
    assert sorted(set(data.curve.tolist())) == list(range(11))
    assert len(data.input) == 642          # 648 lines - 5 comments - 1 header
    assert data.input.max() == pytest.approx(3.5)
    check_excitation(data)


def test_static_input_output_without_curve_is_one_training_curve(tmp_path):
    u = np.linspace(0, 1, 12)
    data = load_data(_write(tmp_path / 's.csv', 'input,output', np.column_stack([u, u ** 2])))
    assert data.kind == 'static'
    np.testing.assert_array_equal(data.curve, np.zeros(12, int))
    np.testing.assert_allclose(data.output, u ** 2, atol=1e-6)


@pytest.mark.parametrize('edit, expected', [
    (lambda ls: ls[:4] + [ls[4].rsplit(',', 1)[0]] + ls[5:],
     r'line 5: 4 field\(s\), the header has 5'),
    (lambda ls: ls[:6] + [ls[6].replace(ls[6].split(',')[3], 'abc', 1)] + ls[7:],
     r"line 7, column 'position': 'abc' is not a number"),
    (lambda ls: ls[:6] + [','.join(['nan'] + ls[6].split(',')[1:])] + ls[7:],
     r"line 7, column 'time': nan \(NaN"),
    (lambda ls: ls[:6] + [','.join([''] + ls[6].split(',')[1:])] + ls[7:],
     r"line 7, column 'time': empty value"),
    (lambda ls: ls[:6] + [','.join(ls[6].split(',')[:1] + ['inf'] + ls[6].split(',')[2:])]
     + ls[7:], r"line 7, column 'duty_a': inf \(NaN or infinite"),
    (lambda ls: ls[:6] + [','.join(ls[6].split(',')[:3] + ['inf'] + ls[6].split(',')[4:])]
     + ls[7:], r"line 7, column 'position': inf \(NaN or infinite"),
    (lambda ls: ls[:10] + [ls[9]] + ls[11:],
     r"line 11, column 'time': 0.3 repeats 0.3 on line 10"),
    (lambda ls: ls[:10] + [ls[11], ls[10]] + ls[12:],
     r"line 12, column 'time': .* goes back from"),
    (lambda ls: ls[:10] + ls[13:],
     r"line 11, column 'time': a gap of 0.2 s after 0.3 s, where the median step is 0.05 s"),
    (lambda ls: [ls[0], ls[1], 'time,duty_a,duty_b,angle,ambient_temperature'] + ls[3:],
     r'missing column\(s\) position \(found time, duty_a, duty_b, angle'),
    (lambda ls: [ls[0], ls[1], 'time,duty_a,duty_a,position,ambient_temperature'] + ls[3:],
     r"column 'duty_a' appears twice"),
    (lambda ls: ls[:3], r'no data rows after the header \(line 3\)'),
    (lambda ls: ls[:2], r'empty file'),
    (lambda ls: ls[:11], r'8 data row\(s\); a dynamic record needs at least 10'),
])
def test_malformed_dynamic_csv_names_file_line_and_column(dynamic_csv, edit, expected):
    # file lines: 1 comment, 2 blank, 3 header, 4.. data (time 0, 0.05, ...)
    path = _rewrite(dynamic_csv, edit(_lines(dynamic_csv)))
    with pytest.raises(DataError, match=expected) as err:
        load_data(path)
    assert str(err.value).startswith(str(path))


def test_duty_out_of_range_is_reported_as_a_fraction_problem(tmp_path):
    t, da, db, pos = _dynamic_rows()
    da[7] = 55.0
    path = _write(tmp_path / 'pct.csv', 'time,duty_a,duty_b,position',
                  np.column_stack([t, da, db, pos]))
    with pytest.raises(DataError, match=r"line 9, column 'duty_a': 55 is outside \[0, 1\]"):
        load_data(path)


def test_static_errors(tmp_path):
    path = _write(tmp_path / 'c.csv', 'curve,voltage,deflection',
                  [[0, 0, 0], [0, 1, 1], [1.5, 0, 0], [1.5, 1, 1]])
    with pytest.raises(DataError, match=r"line 4, column 'curve': 1.5 is not a curve number"):
        load_data(path)
    # an integer too large for a curve id once wrapped to a negative int64 in the cast
    path = _write(tmp_path / 'big.csv', 'input,output,curve',
                  [[0, 0, 0], [1, 1, 0], [0, 0, 1e300], [1, 1, 1e300]])
    with warnings.catch_warnings():
        warnings.simplefilter('error')   # no RuntimeWarning from the cast on the way
        with pytest.raises(DataError, match=r"line 4, column 'curve': 1e\+300 is not a curve"):
            load_data(path)
    path = _write(tmp_path / 'odd.csv', 'input,output,curve', [[0, 0, 1], [1, 1, 1]])
    with pytest.raises(DataError, match='no even-numbered curve'):
        load_data(path)
    path = _write(tmp_path / 'half.csv', 'curve,voltage', [[0, 0], [0, 1]])
    with pytest.raises(DataError, match='a static CSV needs input,output or '
                                        'voltage,deflection'):
        load_data(path)


def test_unknown_header_and_headerless_files_explain_the_formats(tmp_path):
    with pytest.raises(DataError, match='cannot tell the data kind .* a dynamic CSV needs'):
        load_data(_write(tmp_path / 'a.csv', 'x,y', [[1, 2], [3, 4]]))
    with pytest.raises(DataError, match='first row holds numbers, not column names'):
        load_data(_write(tmp_path / 'b.csv', '0,1', [[1, 2], [3, 4]]))


def test_missing_file_binary_file_and_directory(tmp_path):
    with pytest.raises(DataError, match='no such file'):
        load_data(tmp_path / 'nope.csv')
    (tmp_path / 'bin.csv').write_bytes(b'\xff\xfe\x00garbage\x80')
    with pytest.raises(DataError, match='not a text CSV file'):
        load_data(tmp_path / 'bin.csv')
    with pytest.raises(DataError, match='directory without an .mcap'):
        load_data(tmp_path)


def test_too_little_excitation(tmp_path):
    t, da, db, pos = _dynamic_rows()
    path = _write(tmp_path / 'flat.csv', 'time,duty_a,duty_b,position',
                  np.column_stack([t, np.full_like(t, 0.3), np.zeros_like(t), pos]))
    with pytest.raises(DataError, match='too little excitation: duty_a and duty_b hardly vary'):
        check_excitation(load_data(path), path)
    check_excitation(load_data(path), path, to_fit=False)   # a step from rest tests a model
    path = _write(tmp_path / 'still.csv', 'time,duty_a,duty_b,position',
                  np.column_stack([t, da, db, np.full_like(t, 0.1)]))
    for to_fit in (True, False):
        with pytest.raises(DataError, match='position is constant'):
            check_excitation(load_data(path), path, to_fit=to_fit)


def test_mcap_bag_loads_through_load_run(tmp_path):
    from sma_actuator.bag.synthetic import write_demo_run
    bag = write_demo_run(tmp_path / 'demo', duration_s=1.0)
    data = load_data(bag)
    assert isinstance(data, DynamicData)
    assert len(data) == 101 and data.dt == pytest.approx(0.01)
    assert data.ambient is not None and np.all(data.ambient == 22.0)
    assert np.all(np.isfinite(data.setpoint))       # leading NaN filled by the first value
    assert data.duty_a.max() > 0 and np.all(data.duty_b == 0)
    mcap = next(bag.glob('*.mcap'))
    assert len(load_data(mcap, rate_hz=50)) == 51   # the file itself, resampled


def _without_joint_states(bag, out_dir, start_s, stop_s):
    """Return a copy of `bag` without the joint states from start_s to stop_s [s] (open)."""
    from sma_actuator.bag.reader import BagReader
    from sma_actuator.bag.writer import BagWriter
    reader = BagReader(bag)
    t0 = next(reader.messages()).log_time_ns
    with BagWriter(out_dir) as out:
        for topic in reader.topics.values():
            out.add_topic(topic.name, topic.type)
        for msg in reader.messages():
            if not (msg.topic.endswith('joint_states')
                    and start_s * 1e9 < msg.log_time_ns - t0 < stop_s * 1e9):
                out.write(msg.topic, msg.data, msg.log_time_ns)
    return out_dir


def _blank_positions(path, rows, token):
    """Rewrite data rows `rows` (0-based) of a CSV with `token` in its position field."""
    return edit_positions(path, path, {k: lambda _: token for k in rows})


def test_rows_without_a_position_keep_their_duties_and_a_run_of_them_is_not_scored(tmp_path):
    # a logger writes the duties it commanded and NaN or nothing for a reading it missed:
    # one missing reading is bridged as a dropped sample is, two or more are a gap (a bag's
    # rule), and the samples before the first reading are not measured either
    t, da, db, pos = _dynamic_rows(n=80)
    path = _write(tmp_path / 'r.csv', 'time,duty_a,duty_b,position',
                  np.column_stack([t, da, db, pos]), comments=['# a run'])
    whole = load_data(path)
    _blank_positions(path, [10], 'nan')
    _blank_positions(path, range(30, 40), '')
    _blank_positions(path, range(3), '-nan')   # as C's printf writes it
    notes = []
    data = load_data(path, notes=notes)
    np.testing.assert_array_equal(data.duty_a, whole.duty_a)
    assert np.all(np.isfinite(data.position))
    assert data.position[10] == pytest.approx(0.5 * (pos[9] + pos[11]), abs=1e-6)
    lost = np.zeros(80, bool)
    lost[[0, 1, 2]] = lost[30:40] = True
    np.testing.assert_array_equal(data.scored_mask(), ~lost)
    assert notes == [f'{path}: 14 row(s) without a position (NaN or empty; the first on line '
                     '3): interpolated from the rows around them, held at the ends',
                     f'{path}: the 13 samples in gaps of the position (over 2.5 median steps, '
                     'or before its first or after its last reading) are simulated but '
                     'neither fitted nor scored']
    _blank_positions(path, range(80 - 4), '')
    with pytest.raises(DataError, match=r'r.csv: 4 row\(s\) with a position; a dynamic '
                                        'record needs at least 10'):
        load_data(path)


def test_signals_logged_only_when_they_change_are_held_as_a_bag_holds_them(tmp_path):
    # a logger that writes a command only when it changes, or streams of several rates
    # merged on one time column, leaves the other rows empty: each row holds the value
    # above it, a duty is 0 before its first value and ambient and setpoint take their first
    t, _, _, pos = _dynamic_rows(n=60)
    duty = np.repeat([0.0, 0.3, 0.7, 0.2], 15)
    ambient = np.repeat([21.5, 22.0, 22.5], 20)
    setpoint = np.repeat([0.1, -0.2, 0.4], 20)
    header = 'time,duty_a,duty_b,position,ambient_temperature,setpoint'
    table = np.column_stack([t, duty, np.zeros(60), pos, ambient, setpoint])
    whole = load_data(_write(tmp_path / 'whole.csv', header, table))
    sparse = [line.split(',') for line in _lines(tmp_path / 'whole.csv')]
    for k, fields in enumerate(sparse[1:]):
        logged_duty = k == 15 or k == 30 or k == 45     # the changes only: 0 is never written
        fields[1] = fields[1] if logged_duty else ''
        fields[2] = ''                                  # a second wire that is not there
        fields[4] = fields[4] if k % 10 == 0 and k else 'nan'   # a slow sensor, from row 10
        fields[5] = fields[5] if k in (2, 20, 40) else ''
    notes = []
    data = load_data(_rewrite(tmp_path / 'sparse.csv', [','.join(f) for f in sparse]),
                     notes=notes)
    for name in ('duty_a', 'duty_b', 'position', 'ambient', 'setpoint'):
        np.testing.assert_array_equal(getattr(data, name), getattr(whole, name), err_msg=name)
    assert data.layout == 'single' and data.scored is None
    path = tmp_path / 'sparse.csv'
    assert notes == [
        f'{path}: duty_a is empty or NaN on 57 row(s) (the first on line 2): held from the '
        'last value above it (0 before the first)',
        f'{path}: duty_b holds no value: 0 throughout',
        f'{path}: ambient_temperature is empty or NaN on 55 row(s) (the first on line 2): '
        'held from the last value above it (the first value before the first)',
        f'{path}: setpoint is empty or NaN on 57 row(s) (the first on line 2): held from the '
        'last value above it (the first value before the first)']
    for fields in sparse[1:]:
        fields[5] = 'nan'
    notes = []
    assert load_data(_rewrite(path, [','.join(f) for f in sparse]), notes=notes).setpoint is None
    assert notes[-1] == f'{path}: setpoint holds no value: left out'


def test_columns_the_formats_do_not_name_are_neither_read_nor_checked(dynamic_csv):
    # a pandas index (no name), a logger's state text, two unnamed columns: only the
    # formats' columns are parsed, so none of them is an error
    whole = load_data(dynamic_csv)
    lines = _lines(dynamic_csv)
    head = lines.index(next(x for x in lines if x.startswith('time')))
    extra = [f'{k - head - 1},' if k > head else ',' for k in range(len(lines))]
    lines = [x if k < head else extra[k] + x + (',state,,' if k == head else ',HEAT ON,,x')
             for k, x in enumerate(lines)]
    data = load_data(_rewrite(dynamic_csv, lines))
    for name in ('time', 'duty_a', 'duty_b', 'position', 'ambient'):
        np.testing.assert_array_equal(getattr(data, name), getattr(whole, name), err_msg=name)


def test_a_column_map_reads_a_csv_by_its_own_column_names(tmp_path):
    # a PlotJuggler export: time in ns since the epoch, topic paths as names, each stream's
    # fields empty on the other's rows
    t, da, db, pos = _dynamic_rows()
    header = '__time,/sma/duty/data[0],/sma/duty/data[1],/sma/joint_states/shaft/position'
    stamps = np.round(t * 1e9).astype(np.int64) + 1_766_147_454_000_000_000
    rows = [f'{s},{a:.6g},{b:.6g},{y:.6g}' for s, a, b, y in zip(stamps, da, db, pos)]
    rows[5] = rows[5].rsplit(',', 1)[0] + ','   # a duty message alone on its row
    rows[6] = ','.join(rows[6].split(',')[:1] + ['', ''] + rows[6].split(',')[3:])
    path = _rewrite(tmp_path / 'pj.csv', [header] + rows)
    renames = parse_column_map(['time[ns]=__time', ' duty_a = /SMA/duty/data[0]',
                                'duty_b=/sma/duty/data[1]',
                                'position[mm]=/sma/joint_states/shaft/position'])
    loaded = load_data(path, renames=renames, notes=[])
    np.testing.assert_allclose(loaded.time - loaded.time[0], t, atol=1e-6)
    np.testing.assert_allclose(loaded.duty_a[[5, 6]], [da[5], da[5]], atol=1e-6)
    assert loaded.position[5] == pytest.approx(0.5 * (pos[4] + pos[6]), abs=1e-6)
    assert loaded.position_unit == 'mm'
    with pytest.raises(DataError, match=r'cannot tell the data kind .* a column named '
                                        'otherwise: --column NAME=HEADER'):
        load_data(path)
    with pytest.raises(DataError, match=r'missing column\(s\) duty_a, position .* a column '
                                        'named otherwise: --column NAME=HEADER'):
        load_data(path, renames=parse_column_map(['time[ns]=__time']))
    with pytest.raises(ValueError, match=r"'POT' is given twice \(case is ignored\)"):
        parse_column_map(['position=pot', 'setpoint=POT'])


@pytest.mark.parametrize('pair', ['speed=x', 'position', 'position=', '=pot',
                                  'position[mm=pot'])
def test_a_malformed_column_pair_is_refused(pair):
    with pytest.raises(ValueError, match='is not NAME=HEADER with NAME one of time, duty_a'):
        parse_column_map([pair])


@pytest.mark.slow
def test_a_csv_gap_in_the_positions_is_scored_as_the_same_gap_in_a_bag(tmp_path):
    # one rule for a reading the sensor did not deliver, whichever file holds the record
    from test_workbench_batch import _record, _write_bag, _write_csv
    rec = _record('none', 5)
    _write_bag(tmp_path / 'full', rec)
    bag = load_data(_without_joint_states(tmp_path / 'full', tmp_path / 'cut', 40.0, 60.0))
    gap = ~bag.scored_mask()
    assert gap.sum() == 200
    _write_csv(tmp_path / 'r.csv', rec)
    csv = load_data(_blank_positions(tmp_path / 'r.csv', np.flatnonzero(gap), 'nan'))
    np.testing.assert_array_equal(csv.scored_mask(), bag.scored_mask())
    np.testing.assert_allclose(csv.position, bag.position, atol=1e-5)


def test_a_bag_with_a_gap_in_its_joint_states_loads_with_a_note(tmp_path):
    # as a CSV bridges a dropped sample and refuses a longer gap, a bag says where the
    # position was interpolated over more than MAX_BRIDGED_STEPS median steps, and those
    # samples are not scored
    from sma_actuator.bag.synthetic import write_demo_run
    bag = write_demo_run(tmp_path / 'demo', duration_s=2.0)
    cut = _without_joint_states(bag, tmp_path / 'cut', 0.5, 1.5)
    notes = []
    data = load_data(cut, notes=notes)
    assert len(data) == 201
    assert len(notes) == 2 and notes[0].startswith(f'{cut}: a gap of 1.0') and (
        'interpolated, not measured') in notes[0]
    assert notes[1] == f'{cut}: the 99 samples in the gaps are simulated but neither fitted ' \
        'nor scored'
    gap = (data.time > 0.5 + 1e-9) & (data.time < 1.5 - 1e-9)   # 0.51 s to 1.49 s
    np.testing.assert_array_equal(data.scored_mask(), ~gap)
    notes = []
    assert load_data(bag, notes=notes).scored is None
    assert notes == []


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.mark.slow
def test_a_bag_gap_is_simulated_but_neither_fitted_nor_scored(tmp_path):
    # a 20 s stretch without joint states while the shaft moves: the straight line the
    # arrays hold there is no measurement, and a fit through it misses the plant
    from test_workbench_batch import _record, _write_bag
    from sma_actuator.workbench.engine import fit_model, record_scores
    from sma_actuator.workbench.records import join
    full = load_data(_write_bag(tmp_path / 'full', _record('none', 5)))
    cut = load_data(_without_joint_states(tmp_path / 'full', tmp_path / 'cut', 40.0, 60.0))
    gap = ~cut.scored_mask()
    assert gap.sum() == 200 and np.ptp(full.position[gap]) > 0.5   # rad: the shaft moved
    fit = fit_model(join([('run', cut)]), [])
    assert fit.train['nrmse'] < 0.002                        # at the 2 mrad noise
    assert _rms(fit.prediction - full.position) < 0.01       # rad: the plant, in the gap too
    pooled = record_scores(join([('run', cut)]), fit.prediction)[0]['scores']['all']
    assert pooled['rmse'] == pytest.approx(_rms((fit.prediction - cut.position)[~gap]))
    through = fit_model(join([('run', replace(cut, scored=None))]), [])   # the line as data
    assert _rms(through.prediction - full.position) > 0.1


def test_unmeasured_samples_stay_unmeasured_when_decimated_resampled_and_joined(tmp_path):
    from sma_actuator.bag.synthetic import write_demo_run
    from sma_actuator.workbench.records import at_fit_rate, join, segment_of, segment_view
    cut = load_data(_without_joint_states(write_demo_run(tmp_path / 'demo', duration_s=4.0,
                                                         joint_state_rate_hz=200.0),
                                          tmp_path / 'cut', 1.0, 2.0))
    slow, note = at_fit_rate(cut)   # 200 Hz -> 100 Hz: the mean of samples 2k - 1 and 2k
    assert note.startswith('decimated from 200 Hz to 100 Hz')
    measured = cut.scored_mask()
    at = 2 * np.arange(len(slow))
    both = measured[at] & measured[np.maximum(at - 1, 0)]
    assert not both.all() and slow.scored_mask().sum() == both.sum() > len(slow) / 2
    np.testing.assert_array_equal(slow.scored_mask(), both)
    other = load_data(write_demo_run(tmp_path / 'other', duration_s=2.0))   # no gap
    joined = join([('other', other), ('cut', cut)])   # cut is resampled to other's 100 Hz
    a, b = segment_of(joined, 'cut')
    view = segment_view(joined, a, b)
    np.testing.assert_array_equal(view.scored_mask(), ~((view.time - view.time[0] > 1.0 + 1e-9)
                                                        & (view.time - view.time[0] < 2.0 - 1e-9)))
    assert segment_view(joined, *segment_of(joined, 'other')).scored is None


def test_broken_bag_is_a_data_error_naming_the_file(tmp_path):
    bad = tmp_path / 'broken.mcap'
    bad.write_bytes(b'\x89MCAP0\r\n' + b'\x00' * 20)
    with pytest.raises(DataError, match='broken.mcap'):
        load_data(bad)


def test_a_csv_cut_off_inside_its_last_row_keeps_the_complete_rows_with_a_note(dynamic_csv):
    text = dynamic_csv.read_text()
    rows = _lines(dynamic_csv)[3:]
    whole = load_data(dynamic_csv)
    before_last = text[:len(text) - len(rows[-1]) - 1]
    # cut before the last field (an empty value), and after the first (too few fields)
    for partial in (rows[-1].rsplit(',', 1)[0] + ',', rows[-1].split(',')[0] + ',0.1'):
        dynamic_csv.write_text(before_last + partial)
        notes = []
        data = load_data(dynamic_csv, notes=notes)
        assert len(data) == len(rows) - 1
        np.testing.assert_array_equal(data.position, whole.position[:-1])
        assert notes == [f'{dynamic_csv}: the file ends inside line {len(rows) + 3} (a log '
                         f'stopped while it was written): that row is left out, '
                         f'{len(rows) - 1} rows read']


def test_a_csv_cut_off_inside_its_last_position_leaves_that_row_out(tmp_path):
    # the position is the last field of a logger's row: an empty one there is the cut,
    # not a reading the sensor missed
    t, da, db, pos = _dynamic_rows()
    path = _write(tmp_path / 'r.csv', 'time,duty_a,duty_b,position',
                  np.column_stack([t, da, db, pos]))
    text = path.read_text()
    path.write_text(text[:text.rindex(',') + 1])
    notes = []
    data = load_data(path, notes=notes)
    assert len(data) == len(t) - 1 and data.scored is None
    assert notes == [f'{path}: the file ends inside line {len(t) + 1} (a log stopped while it '
                     f'was written): that row is left out, {len(t) - 1} rows read']


def test_a_short_last_row_that_ends_with_a_line_end_is_still_an_error(dynamic_csv):
    # only a file that ends inside its last row was cut off; the same row ended is malformed
    lines = _lines(dynamic_csv)
    path = _rewrite(dynamic_csv, lines[:-1] + [lines[-1].rsplit(',', 2)[0]])
    with pytest.raises(DataError, match=rf'line {len(lines)}: 3 field\(s\), the header has 5'):
        load_data(path)
    # and a malformed row before the cut one is an error too
    path.write_text('\n'.join(lines[:5] + ['0.1,abc'] + lines[5:])[:-3])
    with pytest.raises(DataError, match=r'line 6: 2 field\(s\)'):
        load_data(path)


def _glitch_rows(n, runs):
    """Return a mask of `runs` ((first row, samples), ...) in n rows."""
    mask = np.zeros(n, bool)
    for first, samples in runs:
        mask[first:first + samples] = True
    return mask


def test_a_few_samples_jumping_away_and_back_are_glitches_and_a_wires_moves_are_not():
    # the package's plant (steps, reversals, 1 mrad noise, ADC steps) at 10 and 100 Hz
    # holds no glitch; runs of 1 to 3 samples lifted or dropped by 60 % of its range are
    # found exactly, and 4 samples off are a move, not a glitch
    from support import plant_records
    from sma_actuator.workbench.glitches import glitch_mask
    for rate_hz in (10.0, 100.0):
        y = plant_records.simulate('none', 0, duration_s=120.0, rate_hz=rate_hz, seed=3)
        y = np.asarray(y['position'], float)
        assert not glitch_mask(y)[0].any()
        runs = [(int(f * y.size), samples) for f, samples in
                ((0.2, 1), (0.4, 2), (0.6, 3), (0.8, 4))]
        lifted = y + np.ptp(y) * 0.6 * np.where(np.arange(y.size) < y.size // 2, 1, -1) * \
            _glitch_rows(y.size, runs)
        found, clearance = glitch_mask(lifted)
        np.testing.assert_array_equal(found, _glitch_rows(y.size, runs[:3]))
        assert 0 < clearance < 0.5 * np.ptp(y)
    # a record that barely moves: its noise, and the quanta of a coarse sensor, are no glitch
    rng = np.random.default_rng(4)
    for noise in (rng.normal(0.0, 1.0, 24000), np.round(rng.normal(0.0, 0.6, 24000))):
        assert not glitch_mask(noise + np.repeat([0.0, 20.0], 12000))[0].any()


def test_above_100_hz_a_glitch_may_last_30_ms():
    # at 1 kHz a wiper's lift-off of 10 or 25 ms spans 10 or 25 samples: glitches, bridged
    # close to the clean record; 40 samples off are a move, and the clean record holds none
    from support import plant_records
    from sma_actuator.workbench.timegrid import leave_out_glitches
    rec = plant_records.simulate('none', 0, duration_s=60.0, rate_hz=1000.0, seed=3)
    y = np.asarray(rec['position'], float)
    runs = [(int(f * y.size), samples) for f, samples in ((0.3, 10), (0.6, 25), (0.8, 40))]
    lifted = y + 0.6 * np.ptp(y) * _glitch_rows(y.size, runs)
    time, notes = np.arange(y.size) * 1e-3, []
    assert leave_out_glitches('r.csv', {'time': time, 'position': y}, None, notes) is None
    cols = {'time': time, 'position': lifted}
    scored = leave_out_glitches('r.csv', cols, None, notes)
    glitch = _glitch_rows(y.size, runs[:2])
    np.testing.assert_array_equal(scored, ~glitch)
    np.testing.assert_allclose(cols['position'][glitch], y[glitch], atol=0.02 * np.ptp(y))
    assert len(notes) == 1 and 'and back within 30 samples' in notes[0]


WIRE_STEP = Path(REAL).parent / 'spring_biased_wire' / 'step_a.csv'


@pytest.mark.slow
@pytest.mark.skipif(not WIRE_STEP.is_file(), reason='shared data not found')
def test_sensor_glitches_in_a_measured_record_are_bridged_and_neither_fitted_nor_scored(
        tmp_path, capsys):
    # a wiper that lifts off its track: eight single samples 12 mm up and one pair 5 mm down
    # in the measured wire's step record. They are bridged from the samples around them, are
    # not scored, and the record fits and scores as the clean one does
    from sma_actuator.workbench import cli
    rows = [516, 900, 1300, 1801, 2222, 3000, 3900, 4700]
    offsets = dict.fromkeys(rows, 12.0)
    offsets.update({2500: -5.0, 2501: -5.0})
    added = {row: shifted(offset) for row, offset in offsets.items()}
    path = edit_positions(WIRE_STEP, tmp_path / 'step_glitches.csv', added)
    notes = []
    data, clean = load_data(path, notes=notes), load_data(WIRE_STEP)
    glitch = np.zeros(len(clean), bool)
    glitch[list(offsets)] = True
    np.testing.assert_array_equal(data.scored_mask(), ~glitch)
    np.testing.assert_allclose(data.position, clean.position, atol=0.05)   # mm
    assert data.span() == clean.span()
    assert notes == [f'{path}: 10 position sample(s) (the first at 5.160 s) jump away by over '
                     "9.9 % of the record's range and back within 3 samples: read as sensor "
                     'glitches, bridged, neither fitted nor scored (--keep-glitches reads '
                     'them as measured)']
    kept = load_data(path, notes=notes, keep_glitches=True)
    assert kept.scored is None and len(notes) == 1
    np.testing.assert_allclose(kept.position[glitch] - clean.position[glitch],
                               [offsets[row] for row in sorted(offsets)], atol=1e-9)
    scores = []
    for args in ([path], [WIRE_STEP], [path, '--keep-glitches']):
        assert cli.main(['fit', *map(str, args), '--json']) == 0
        scores.append(json.loads(capsys.readouterr().out))
    for part in ('train', 'validation'):
        assert scores[0][part]['nrmse'] == pytest.approx(scores[1][part]['nrmse'], abs=2e-4)
    assert scores[2]['train']['rmse'] > 2 * scores[1]['train']['rmse']   # read as measured


def test_a_glitch_in_a_bags_joint_states_is_bridged_as_in_a_csv(tmp_path):
    from test_workbench_batch import _record, _write_bag
    rec = _record('none', 5)
    rec['position'][[300, 301]] += 3.0   # rad: two joint states far off
    notes = []
    data = load_data(_write_bag(tmp_path / 'glitch', rec), notes=notes)
    lost = np.zeros(len(data), bool)
    lost[[300, 301]] = True
    np.testing.assert_array_equal(data.scored_mask(), ~lost)
    assert np.abs(data.position[lost] - rec['position'][lost] + 3.0).max() < 0.05   # rad
    assert len(notes) == 1 and 'read as sensor glitches' in notes[0]
