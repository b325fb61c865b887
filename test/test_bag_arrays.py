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

"""load_run: aligned arrays with interpolation/ZOH as documented, named errors on bad input."""
import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer as RosbagsWriter
from rosbags.typesys import get_typestore, Stores
from sma_actuator.bag.arrays import load_run, zero_order_hold
from sma_actuator.bag.errors import (BagError, BagNotFoundError, MissingTopicError, NotMcapError,
                                     TruncatedBagError, UnknownTypeError)
from sma_actuator.bag.synthetic import stamp, to_cdr
from sma_actuator.bag.writer import BagWriter

T0 = 1_700_000_000_000_000_000
MS = 1_000_000


def _js(position, names=('shaft',)):
    return {'header': {'stamp': stamp(T0)}, 'name': list(names),
            'position': list(position), 'velocity': [0.0] * len(position)}


def _events(js_times_ms, position_of_t, duty=(), setpoint=(), ambient=(), js_topic=None):
    """[(topic, type, message dict, log time ns)] for a run; times in ms from T0."""
    out = [(js_topic or '/sma/joint_states', 'sensor_msgs/msg/JointState',
            _js([position_of_t(t * 1e-3)]), T0 + int(round(t * MS))) for t in js_times_ms]
    out += [('/sma/duty', 'std_msgs/msg/Float64MultiArray', {'data': list(v)},
             T0 + int(t * MS)) for t, v in duty]
    out += [('/sma/setpoint', 'std_msgs/msg/Float64', {'data': v}, T0 + int(t * MS))
            for t, v in setpoint]
    out += [('/sma/ambient_temperature', 'sensor_msgs/msg/Temperature',
             {'temperature': v}, T0 + int(t * MS)) for t, v in ambient]
    return sorted(out, key=lambda e: e[3])


def _write(path, events, **options):
    payloads = to_cdr([(type_name, msg) for _, type_name, msg, _ in events])
    with BagWriter(path, **options) as bag:
        for (topic, type_name, _, log), data in zip(events, payloads):
            bag.add_topic(topic, type_name)
            bag.write(topic, data, log)
    return path


DUTY = [(105, (0.3, 0.1)), (500, (0.0, 0.7))]
SETPOINT = [(200, 0.25), (700, -0.1)]
AMBIENT = [(300, 21.5), (600, 22.0)]


@pytest.fixture
def run(tmp_path):
    events = _events(range(0, 1001, 10), lambda t: 0.5 + 0.1 * t, DUTY, SETPOINT, AMBIENT)
    return _write(tmp_path / 'run', events)


def test_grid_is_uniform_at_the_joint_state_rate_from_the_first_joint_state(run):
    arrays = load_run(run)
    assert list(arrays) == ['time', 'duty_a', 'duty_b', 'position', 'ambient_temperature',
                            'setpoint']
    np.testing.assert_allclose(arrays['time'], np.arange(101) * 0.01, atol=1e-12)
    assert all(len(v) == 101 for v in arrays.values())


def test_commands_are_held_and_zero_before_the_first(run):
    a = load_run(run)
    t = a['time']
    expected_a = np.where(t < 0.105, 0.0, np.where(t < 0.5, 0.3, 0.0))
    expected_b = np.where(t < 0.105, 0.0, np.where(t < 0.5, 0.1, 0.7))
    np.testing.assert_array_equal(a['duty_a'], expected_a)
    np.testing.assert_array_equal(a['duty_b'], expected_b)
    assert a['duty_b'][50] == 0.7, 'a command logged exactly at a grid time applies there'


def test_setpoint_is_held_and_nan_before_the_first(run):
    a = load_run(run)
    t = a['time']
    assert np.isnan(a['setpoint'][t < 0.2 - 1e-9]).all()
    np.testing.assert_array_equal(a['setpoint'][t >= 0.2 - 1e-9],
                                  np.where(t[t >= 0.2 - 1e-9] < 0.7 - 1e-9, 0.25, -0.1))


def test_ambient_is_held_and_backfilled(run):
    a = load_run(run)
    t = a['time']
    np.testing.assert_array_equal(a['ambient_temperature'],
                                  np.where(t < 0.6 - 1e-9, 21.5, 22.0))


def test_position_is_linearly_interpolated_between_irregular_samples(tmp_path):
    rng = np.random.default_rng(3)
    js_ms = np.cumsum(rng.uniform(3.0, 7.0, size=200))  # ~200 Hz with jitter
    path = _write(tmp_path / 'jitter', _events(js_ms, lambda t: 2.0 - 0.3 * t, DUTY))
    a = load_run(path, rate_hz=1000.0)
    np.testing.assert_allclose(np.diff(a['time']), 1e-3, atol=1e-9)
    t_abs = js_ms[0] * 1e-3 + a['time']
    np.testing.assert_allclose(a['position'], 2.0 - 0.3 * t_abs, atol=1e-9)
    assert a['time'][-1] <= (js_ms[-1] - js_ms[0]) * 1e-3 + 1e-9


def test_optional_topics_are_left_out_when_not_recorded(tmp_path):
    path = _write(tmp_path / 'min', _events(range(0, 100, 10), lambda t: t, DUTY))
    assert sorted(load_run(path)) == ['duty_a', 'duty_b', 'position', 'time']


def test_topics_can_be_renamed_and_the_shaft_joint_is_picked(tmp_path):
    events = _events(range(0, 100, 10), lambda t: t, DUTY, js_topic='/measured/joint_states')
    events = [(top, ty, _js([9.0, msg['position'][0]], ('elbow', 'shaft'))
               if 'joint' in top else msg, log) for top, ty, msg, log in events]
    path = _write(tmp_path / 'renamed', events)
    with pytest.raises(MissingTopicError, match=r"'/sma/joint_states'.*topics present"):
        load_run(path)
    a = load_run(path, topics={'joint_states': '/measured/joint_states'})
    np.testing.assert_allclose(a['position'], a['time'])


def _moved(events, namespace):
    return [(top.replace('/sma/', namespace + '/'), ty, msg, log) for top, ty, msg, log in events]


def test_the_actuator_namespace_is_found_in_the_bag(tmp_path):
    events = _events(range(0, 300, 10), lambda t: t, DUTY, SETPOINT)
    path = _write(tmp_path / 'left', _moved(events, '/left'))
    a = load_run(path)
    np.testing.assert_allclose(a['position'], a['time'])
    assert 'setpoint' in a and a['duty_a'][-1] == 0.3


def test_a_bag_of_two_actuators_needs_a_namespace(tmp_path):
    left = _moved(_events(range(0, 100, 10), lambda t: t, DUTY), '/left')
    right = _moved(_events(range(0, 100, 10), lambda t: -t, DUTY), '/right')
    path = _write(tmp_path / 'both', sorted(left + right, key=lambda e: e[3]))
    with pytest.raises(BagError, match=r"several actuators \['/left', '/right'\]"):
        load_run(path)
    np.testing.assert_allclose(load_run(path, namespace='/right')['position'],
                               -load_run(path, namespace='/left')['position'])


def test_same_arrays_from_an_independent_rosbag2_writer(run, tmp_path):
    store = get_typestore(Stores.ROS2_JAZZY)
    events = _events(range(0, 1001, 10), lambda t: 0.5 + 0.1 * t, DUTY, SETPOINT, AMBIENT)
    path = tmp_path / 'rosbag2_run'
    with RosbagsWriter(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {}
        # bytes from our encoder, decodable by any CDR reader
        payloads = to_cdr([(type_name, msg) for _, type_name, msg, _ in events])
        for (topic, type_name, _, log), data in zip(events, payloads):
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, type_name, typestore=store)
            writer.write(conns[topic], log, data)
    ours, theirs = load_run(run), load_run(path)
    assert list(ours) == list(theirs)
    for key in ours:
        np.testing.assert_array_equal(ours[key], theirs[key])


def test_a_cut_recording_loads_what_was_recovered(tmp_path):
    events = _events(range(0, 5001, 1), lambda t: t, [(0, (0.5, 0.0))])
    path = _write(tmp_path / 'long', events, chunk_size_bytes=4096)
    data = (path / 'long_0.mcap').read_bytes()
    (path / 'metadata.yaml').unlink()
    (path / 'long_0.mcap').write_bytes(data[:len(data) // 2])
    a = load_run(path)
    assert 0.5 < a['time'][-1] < 5.0
    np.testing.assert_allclose(a['position'], a['time'], atol=1e-9)


def test_a_cut_recording_says_what_it_kept_and_lost_in_the_notes(tmp_path):
    events = _events(range(0, 5001, 1), lambda t: t, [(0, (0.5, 0.0))])
    path = _write(tmp_path / 'long', events, chunk_size_bytes=4096)
    data = (path / 'long_0.mcap').read_bytes()
    (path / 'long_0.mcap').write_bytes(data[:len(data) // 2])
    notes = []
    load_run(path, notes=notes)
    assert len(notes) == 1 and notes[0].startswith(str(path / 'long_0.mcap'))
    assert 'recording did not finish' in notes[0] and 'lost ' in notes[0]
    notes = []
    load_run(_write(tmp_path / 'whole', events), notes=notes, bridged_steps=2.5)
    assert notes == []


def test_joint_state_gaps_beyond_the_bridged_steps_are_noted_not_dropped(tmp_path):
    # 10 ms steps; one message dropped at 200 ms (a 20 ms step is bridged), none from 300 to
    # 700 ms and from 800 to 850 ms
    js_ms = [t for t in range(0, 1001, 10)
             if t != 200 and not 300 < t < 700 and not 800 < t < 850]
    path = _write(tmp_path / 'gaps', _events(js_ms, lambda t: 0.5 + 0.1 * t, DUTY))
    notes = []
    a = load_run(path, notes=notes, bridged_steps=2.5)
    assert notes == [f'{path}: 2 gaps in the joint states (over 2.5 median steps of 0.01 s; '
                     '0.450 s in all), the longest 0.400 s from 0.300 s after the first: the '
                     'position there is interpolated, not measured']
    np.testing.assert_allclose(a['time'], np.arange(101) * 0.01, atol=1e-12)
    np.testing.assert_allclose(a['position'], 0.5 + 0.1 * a['time'], atol=1e-9)
    ms = np.round(a['time'] * 1000)   # grid points strictly inside the two gaps
    np.testing.assert_array_equal(a['position_measured'],
                                  ~(((ms > 300) & (ms < 700)) | ((ms > 800) & (ms < 850))))
    quiet = []
    assert load_run(path, notes=quiet, bridged_steps=50.0)['position_measured'].all()
    assert quiet == [] and 'position_measured' not in load_run(path)


@pytest.mark.parametrize('make, error, problem', [
    (lambda p: None, BagNotFoundError, 'no such file'),
    (lambda p: p.write_bytes(b''), TruncatedBagError, 'empty'),
    (lambda p: p.write_text('time,duty_a\n0,0\n'), NotMcapError, 'not an MCAP file'),
])
def test_unreadable_files_are_named(tmp_path, make, error, problem):
    path = tmp_path / 'bad.mcap'
    make(path)
    with pytest.raises(error, match=problem) as info:
        load_run(path)
    assert str(path) in str(info.value)


def test_file_with_no_complete_chunk_is_truncated(run, tmp_path):
    data = (run / 'run_0.mcap').read_bytes()
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:200])
    with pytest.raises(TruncatedBagError, match='nothing was recovered'):
        load_run(cut)


def test_missing_duty_is_named(tmp_path):
    path = _write(tmp_path / 'noduty', _events(range(0, 100, 10), lambda t: t))
    with pytest.raises(MissingTopicError, match=r"noduty.*'/sma/duty'"):
        load_run(path)


def test_wrong_type_on_a_topic_is_named(tmp_path):
    events = _events(range(0, 100, 10), lambda t: t)
    events.append(('/sma/duty', 'std_msgs/msg/Float64', {'data': 0.5}, T0 + 5 * MS))
    path = _write(tmp_path / 'wrongtype', events)
    with pytest.raises(UnknownTypeError, match=r"'/sma/duty' has type 'std_msgs/msg/Float64'"):
        load_run(path)


def test_duty_with_wrong_length_is_named(tmp_path):
    path = _write(tmp_path / 'd3', _events(range(0, 100, 10), lambda t: t, [(0, (0.1, 0.2, 0.3))]))
    with pytest.raises(ValueError, match=r'd3.*3 values'):
        load_run(path)


@pytest.mark.parametrize('kwargs, problem', [
    ({'rate_hz': 0}, 'rate_hz'),
    ({'rate_hz': float('nan')}, 'rate_hz'),
    ({'topics': {'duty_cycle': '/x'}}, 'duty_cycle'),
])
def test_bad_arguments_are_rejected(run, kwargs, problem):
    with pytest.raises(ValueError, match=problem):
        load_run(run, **kwargs)


def test_zero_order_hold_semantics():
    times = np.array([10, 20, 30])
    values = np.array([1.0, 2.0, 3.0])
    held = zero_order_hold(times, values, np.array([5, 10, 15, 20, 35]), before=-1.0)
    np.testing.assert_array_equal(held, [-1.0, 1.0, 1.0, 2.0, 3.0])


def test_a_jump_in_log_time_is_reported_not_allocated(tmp_path):
    """E.g. messages logged at time 0 (sim time before /clock) and then at epoch time."""
    events = _events(range(0, 1000, 10), lambda t: t, DUTY)
    events = [(top, ty, msg, log - T0 if 'joint' in top and log < T0 + 30 * MS else log)
              for top, ty, msg, log in events]  # the first three joint states at time ~0
    path = _write(tmp_path / 'jump', events)
    with pytest.raises(BagError, match=r'jump.*samples \(limit.*sim time before /clock'):
        load_run(path)


def _duty_status(t_ms, held, clamped, name='hardware_bridge: duty', hardware_id='/dev/ttyACM0'):
    """Return a /diagnostics event: one duty status carrying the two counters."""
    values = [{'key': 'commands', 'value': str(3 * t_ms)},
              {'key': 'interlock_held', 'value': held}, {'key': 'clamped', 'value': clamped}]
    msg = {'header': {'stamp': stamp(T0)},
           'status': [{'level': 0, 'name': name, 'message': 'ok',
                       'hardware_id': hardware_id, 'values': values}]}
    return ('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray', msg, T0 + t_ms * MS)


def test_duty_commands_the_diagnostics_count_as_held_or_clamped_are_noted(tmp_path):
    # the bridge restarts at 600 ms: its counters fall to 1 held and count on from there
    counters = [(100, '4', '0'), (350, '9', '0'), (600, '1', '2'), (900, '3', 'n/a')]
    events = _events(range(0, 1001, 10), lambda t: 0.5 + 0.1 * t, DUTY) + [
        _duty_status(t, held, clamped) for t, held, clamped in counters]
    path = _write(tmp_path / 'held', sorted(events, key=lambda e: e[3]))
    notes = []
    plain = load_run(path, notes=notes)
    assert notes == [f'{path}: hardware_bridge: duty (/dev/ttyACM0) held 8 duty commands at '
                     'the dead-time interlock and clamped 2 to max_duty while recorded: '
                     '/sma/duty logs them as sent, not as applied']
    # the note changes nothing loaded; counters that never rise say nothing
    np.testing.assert_array_equal(plain['duty_a'], load_run(tmp_path / 'held')['duty_a'])
    steady = _events(range(0, 1001, 10), lambda t: 0.5, DUTY) + [
        _duty_status(t, '7', '1') for t in (100, 600)]
    quiet = []
    load_run(_write(tmp_path / 'steady', sorted(steady, key=lambda e: e[3])), notes=quiet)
    assert quiet == []


def test_the_duty_the_bridge_applied_is_loaded_in_place_of_the_commands(tmp_path):
    # the bridge held wire b's command for the dead time and sent the 0.9 clamped to 0.7
    applied = [(106, (0.3, 0.0)), (160, (0.3, 0.1)), (500, (0.0, 0.0)), (551, (0.0, 0.7))]
    events = _events(range(0, 1001, 10), lambda t: 0.5 + 0.1 * t, DUTY) + [
        ('/sma/applied_duty', 'std_msgs/msg/Float64MultiArray', {'data': list(v)},
         T0 + t * MS) for t, v in applied] + [_duty_status(300, '0', '0'),
                                              _duty_status(800, '1', '0')]
    path = _write(tmp_path / 'bridge', sorted(events, key=lambda e: e[3]))
    notes = []
    a = load_run(path, notes=notes)
    t = a['time']
    expected_b = np.where(t < 0.16, 0.0, np.where(t < 0.5, 0.1, np.where(t < 0.551, 0.0, 0.7)))
    np.testing.assert_array_equal(a['duty_b'], expected_b)
    np.testing.assert_array_equal(a['duty_a'], np.where((t >= 0.106) & (t < 0.5), 0.3, 0.0))
    assert notes == [f'{path}: duty read from /sma/applied_duty, as the hardware applied it, '
                     'not from the commands on /sma/duty',
                     f'{path}: hardware_bridge: duty (/dev/ttyACM0) held 1 duty command at the '
                     'dead-time interlock while recorded: the duty is read from '
                     '/sma/applied_duty, as applied']
    # asked for, the commands as logged
    commands = load_run(path, topics={'applied_duty': ''})
    np.testing.assert_array_equal(commands['duty_b'],
                                  np.where(t < 0.105, 0.0, np.where(t < 0.5, 0.1, 0.7)))


def test_undecodable_diagnostics_are_noted_and_the_run_still_loads(tmp_path):
    events = _events(range(0, 1001, 10), lambda t: 0.5 + 0.1 * t, DUTY)
    path = _write(tmp_path / 'garbled', events)
    with BagWriter(tmp_path / 'garbled2') as bag:
        payloads = to_cdr([(type_name, msg) for _, type_name, msg, _ in events])
        for (topic, type_name, _, log), data in zip(events, payloads):
            bag.add_topic(topic, type_name)
            bag.write(topic, data, log)
        bag.add_topic('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray')
        bag.write('/diagnostics', b'\x00\x01\x00\x00\xff', T0 + 500 * MS)
    notes = []
    garbled = load_run(tmp_path / 'garbled2', notes=notes)
    assert len(notes) == 1 and notes[0].startswith(
        f'{tmp_path / "garbled2"}: /diagnostics cannot be decoded (')
    assert notes[0].endswith('), so whether a node held or clamped the commands on /sma/duty '
                             'is not known')
    np.testing.assert_array_equal(garbled['position'], load_run(path)['position'])
