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

"""BagWriter output follows rosbag2_storage_mcap conventions and reads back independently."""
from pathlib import Path
import shutil

from mcap.reader import make_reader
import pytest
from rosbags.highlevel import AnyReader
from sma_actuator.bag import writer as writer_module
from sma_actuator.bag.errors import BagExistsError, BagWriteError
from sma_actuator.bag.msgdefs import DELIMITER, message_definition, type_description_hash
from sma_actuator.bag.qos import load_offered_qos_profiles
from sma_actuator.bag.reader import BagReader
from sma_actuator.bag.synthetic import cdr_encoder, offered_profile, SMA_TOPICS, stamp, to_cdr
from sma_actuator.bag.writer import BagWriter
import yaml

T0 = 1_700_000_000_123_456_789


def _message(topic, i):
    """Return a distinct, known message dict for message number i on a topic."""
    type_name = SMA_TOPICS[topic][0]
    t = T0 + i * 1_000_000
    if type_name.endswith('Float64'):
        return {'data': 0.001 * i}
    if type_name.endswith('Float64MultiArray'):
        return {'data': [i / 1000.0, 1.0 - i / 1000.0]}
    if type_name.endswith('JointState'):
        return {'header': {'stamp': stamp(t)}, 'name': ['shaft'], 'position': [0.01 * i],
                'velocity': [0.5], 'effort': []}
    if type_name.endswith('Temperature'):
        return {'header': {'stamp': stamp(t), 'frame_id': 'wire_a'},
                'temperature': 20.0 + i, 'variance': 0.0}
    return {'header': {'stamp': stamp(t)},
            'status': [{'level': 0, 'name': 'n', 'message': f'm{i}', 'hardware_id': 'h',
                        'values': [{'key': 'k', 'value': str(i)}]}]}


def _write_bag(path, count=40, **options):
    """Write ``count`` messages on every contract topic; return [(topic, bytes, log, pub)]."""
    order = [(i, k, topic) for i in range(count) for k, topic in enumerate(SMA_TOPICS)]
    payloads = iter(to_cdr([(SMA_TOPICS[topic][0], _message(topic, i)) for i, _, topic in order]))
    written = []
    with BagWriter(path, **options) as bag:
        for topic, (type_name, reliability) in SMA_TOPICS.items():
            bag.add_topic(topic, type_name, [offered_profile(reliability)])
        for i, k, topic in order:
            data = next(payloads)
            log, pub = T0 + i * 1_000_000 + k * 1000 + 500, T0 + i * 1_000_000 + k * 1000
            bag.write(topic, data, log, pub)
            written.append((topic, data, log, pub))
    return written


@pytest.fixture
def bag(tmp_path):
    path = tmp_path / 'run1'
    return path, _write_bag(path, chunk_size_bytes=2048)


def _plain(value):
    """Turn rosbags/mcap_ros2 message objects into comparable plain data."""
    if hasattr(value, '__dataclass_fields__'):
        return {k: _plain(getattr(value, k)) for k in value.__dataclass_fields__
                if k != '__msgtype__'}
    if hasattr(value, 'tolist'):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def test_layout_is_a_rosbag2_directory(bag):
    path, _ = bag
    assert sorted(p.name for p in path.iterdir()) == ['metadata.yaml', 'run1_0.mcap']


@pytest.mark.parametrize('target', ['directory', 'mcap file'])
def test_rosbags_reads_back_every_message_unchanged(bag, target):
    path, written = bag
    source = path if target == 'directory' else path / 'run1_0.mcap'
    with AnyReader([source]) as reader:
        assert reader.message_count == len(written)
        assert {c.topic: c.msgtype for c in reader.connections} == {
            t: ty for t, (ty, _) in SMA_TOPICS.items()}
        got = [(c.topic, raw, t) for c, t, raw in reader.messages()]
        decoded = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    assert [(t, bytes(raw), log) for t, raw, log in got] == [(t, d, log) for t, d, log, _ in
                                                             written]
    # content decoded by rosbags equals the values that were encoded
    i_by_topic = {}
    for (topic, _, _, _), msg in zip(written, decoded):
        i = i_by_topic[topic] = i_by_topic.get(topic, -1) + 1
        expected, plain = _message(topic, i), _plain(msg)
        if 'header' in expected:
            assert plain['header']['stamp'] == expected['header']['stamp']
        for key, value in expected.items():
            if key == 'status':
                assert plain['status'][0]['message'] == value[0]['message']
                assert plain['status'][0]['values'][0]['value'] == value[0]['values'][0]['value']
            elif key != 'header':
                assert plain[key] == pytest.approx(value)


def test_mcap_records_follow_rosbag2_storage_mcap(bag):
    path, written = bag
    with open(path / 'run1_0.mcap', 'rb') as f:
        reader = make_reader(f)
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
        assert summary.statistics.message_count == len(written)
        assert len(summary.chunk_indexes) > 1, 'small chunk size must give several chunks'
        assert all(ci.compression == 'zstd' and ci.message_index_offsets
                   for ci in summary.chunk_indexes)
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            type_name, reliability = SMA_TOPICS[channel.topic]
            assert schema.name == type_name
            assert schema.encoding == 'ros2msg'
            assert schema.data.decode() == message_definition(type_name)
            assert channel.message_encoding == 'cdr'
            assert set(channel.metadata) == {'offered_qos_profiles', 'topic_type_hash'}
            assert channel.metadata['topic_type_hash'] == type_description_hash(type_name)
            (qos,) = load_offered_qos_profiles(channel.metadata['offered_qos_profiles'])
            assert qos == offered_profile(reliability)
            assert channel.metadata['offered_qos_profiles'].startswith('- history: keep_last\n')
        (record,) = [m for m in reader.iter_metadata() if m.name == 'rosbag2']
        embedded = yaml.safe_load(record.metadata['serialized_metadata'])
        assert embedded['version'] == 9
        assert embedded['message_count'] == len(written)
    joint = message_definition('sensor_msgs/msg/JointState')
    assert '\n' + DELIMITER + 'MSG: std_msgs/Header\n' in joint


def test_metadata_yaml_describes_the_bag(bag):
    path, written = bag
    info = yaml.safe_load((path / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['version'] == 9
    assert info['storage_identifier'] == 'mcap'
    assert info['relative_file_paths'] == ['run1_0.mcap']
    assert info['message_count'] == len(written)
    logs = [log for _, _, log, _ in written]
    assert info['starting_time']['nanoseconds_since_epoch'] == min(logs)
    assert info['duration']['nanoseconds'] == max(logs) - min(logs)
    assert info['files'][0]['message_count'] == len(written)
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert set(topics) == set(SMA_TOPICS)
    for name, entry in topics.items():
        meta = entry['topic_metadata']
        assert entry['message_count'] == sum(1 for t, *_ in written if t == name)
        assert meta['serialization_format'] == 'cdr'
        assert meta['type_description_hash'] == type_description_hash(meta['type'])
        assert meta['offered_qos_profiles'] == [offered_profile(SMA_TOPICS[name][1])]


@pytest.mark.parametrize('compression', ['lz4', 'none'])
def test_other_compressions_read_back(tmp_path, compression):
    written = _write_bag(tmp_path / 'b', count=10, compression=compression,
                         chunk_size_bytes=1024)
    with AnyReader([tmp_path / 'b']) as reader:
        assert [bytes(raw) for _, _, raw in reader.messages()] == [d for _, d, _, _ in written]
    with open(tmp_path / 'b' / 'b_0.mcap', 'rb') as f:
        expected = '' if compression == 'none' else compression
        assert {ci.compression for ci in make_reader(f).get_summary().chunk_indexes} == {expected}


def test_existing_bag_is_never_overwritten(bag):
    path, _ = bag
    before = {p.name: p.read_bytes() for p in path.iterdir()}
    with pytest.raises(BagExistsError, match=r'run1.*already holds a bag.*overwrite'):
        BagWriter(path)
    assert {p.name: p.read_bytes() for p in path.iterdir()} == before


def test_a_file_in_the_way_is_never_replaced(tmp_path):
    target = tmp_path / 'notes'
    target.write_text('keep me')
    with pytest.raises(BagExistsError, match='not a directory'):
        BagWriter(target)
    assert target.read_text() == 'keep me'


def test_overwrite_replaces_only_when_asked(bag):
    path, _ = bag
    (path / 'notes.txt').write_text('unrelated')
    written = _write_bag(path, count=3, overwrite=True)
    with AnyReader([path]) as reader:
        assert reader.message_count == len(written)
    assert (path / 'notes.txt').read_text() == 'unrelated'


def test_empty_existing_directory_is_used(tmp_path):
    (tmp_path / 'runs' / 'a').mkdir(parents=True)
    assert len(_write_bag(tmp_path / 'runs' / 'a', count=2)) == 2 * len(SMA_TOPICS)


@pytest.mark.parametrize('options', [{'max_file_size_bytes': 6000},
                                     {'max_file_duration_s': 0.01}])
def test_split_files_each_complete_and_together_the_whole_bag(tmp_path, options, monkeypatch):
    monkeypatch.setattr(writer_module, 'MIN_FILE_SIZE_BYTES', 1000)   # small files, fast test
    path = tmp_path / 'split'
    written = _write_bag(path, count=60, chunk_size_bytes=1024, **options)
    files = sorted(path.glob('*.mcap'))
    assert len(files) >= 3
    info = yaml.safe_load((path / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['relative_file_paths'] == [f'split_{i}.mcap' for i in range(len(files))]
    assert sum(f['message_count'] for f in info['files']) == len(written)
    for f in files:
        with open(f, 'rb') as stream:
            summary = make_reader(stream).get_summary()
            assert summary is not None and len(summary.channels) == len(SMA_TOPICS)
    with AnyReader([path]) as reader:
        assert [bytes(raw) for _, _, raw in reader.messages()] == [d for _, d, _, _ in written]


def test_bad_writes_name_the_problem(tmp_path):
    bag = BagWriter(tmp_path / 'b')
    bag.add_topic('/sma/setpoint', 'std_msgs/msg/Float64')
    with pytest.raises(BagWriteError, match="'/nope' was not added"):
        bag.write('/nope', b'', T0)
    with pytest.raises(BagWriteError, match='already added with type'):
        bag.add_topic('/sma/setpoint', 'std_msgs/msg/Float32')
    with pytest.raises(BagWriteError, match='negative log time'):
        bag.write('/sma/setpoint', b'\x00' * 12, -1)
    bag.close()
    with pytest.raises(BagWriteError, match='already closed'):
        bag.write('/sma/setpoint', b'\x00' * 12, T0)
    with pytest.raises(ValueError, match="compression 'gzip'"):
        BagWriter(tmp_path / 'c', compression='gzip')


def test_old_chunks_reach_the_file_before_close(tmp_path, monkeypatch):
    """
    Crash safety.

    After chunk_max_age_s a chunk is on disk, so a copy of the unfinished file (what a SIGKILL
    leaves) is recovered with all messages written before that point.
    """
    clock = [100.0]
    monkeypatch.setattr(writer_module.time, 'monotonic', lambda: clock[0])
    bag = BagWriter(tmp_path / 'live', chunk_max_age_s=0.5)
    bag.add_topic('/sma/setpoint', 'std_msgs/msg/Float64')
    encode = cdr_encoder('std_msgs/msg/Float64')
    for i in range(5):
        bag.write('/sma/setpoint', encode({'data': float(i)}), T0 + i)
    snapshot = tmp_path / 'killed'
    shutil.copytree(tmp_path / 'live', snapshot)
    assert BagReader(snapshot).message_count == 0  # still in memory, nothing on disk yet
    clock[0] += 0.6
    bag.flush_if_due()
    shutil.rmtree(snapshot)
    shutil.copytree(tmp_path / 'live', snapshot)
    reader = BagReader(snapshot)
    assert [m.data for m in reader.messages()] == [encode({'data': float(i)}) for i in range(5)]
    assert reader.recoveries and reader.recoveries[0].lost_bytes == 0
    bag.close()
    assert Path(tmp_path / 'live' / 'metadata.yaml').is_file()


def test_max_file_size_below_the_minimum_is_a_one_line_error(tmp_path):
    with pytest.raises(ValueError, match=r'max_file_size_bytes=100 is below the minimum 65536'):
        BagWriter(tmp_path / 'b', max_file_size_bytes=100)
    BagWriter(tmp_path / 'c', max_file_size_bytes=writer_module.MIN_FILE_SIZE_BYTES).close()


def test_a_split_costs_the_same_however_many_files_came_before(tmp_path, monkeypatch):
    # issue 13 item 9: each split used to serialise the metadata of every file so far
    dumps, yamls = [], []
    dump, write_yaml = writer_module.dump_serialized_metadata, writer_module.write_metadata_yaml
    monkeypatch.setattr(writer_module, 'dump_serialized_metadata',
                        lambda bag: dumps.append(len(bag.files)) or dump(bag))
    monkeypatch.setattr(writer_module, 'write_metadata_yaml',
                        lambda path, bag: yamls.append(len(bag.files)) or write_yaml(path, bag))
    path = tmp_path / 'many'
    payload = bytes(range(256)) * 40   # 10 KiB, incompressible enough
    with BagWriter(path, compression='none', chunk_size_bytes=1024,
                   max_file_size_bytes=writer_module.MIN_FILE_SIZE_BYTES) as bag:
        bag.add_topic('/sma/blob', 'std_msgs/msg/UInt8MultiArray', definition='uint8[] data',
                      type_hash='RIHS01_' + '0' * 64)
        for i in range(400):
            bag.write('/sma/blob', payload, T0 + i * 1000)
    files = sorted(path.glob('*.mcap'))
    assert len(files) >= 40
    assert len(dumps) == len(files)           # one embedded record per file ...
    assert set(dumps) == {1}                  # ... describing that file only
    assert yamls == [len(files)]              # metadata.yaml once, at close, with all files
    info = yaml.safe_load((path / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert sum(f['message_count'] for f in info['files']) == 400
    assert [m.data for m in BagReader(path).messages()] == [payload] * 400


def test_cdr_bytes_read_back_with_rclpy_in_order_across_types():
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64, Float64MultiArray
    items = [('std_msgs/msg/Float64', {'data': 1.5}),
             ('sensor_msgs/msg/JointState', {'header': {'stamp': stamp(T0)}, 'name': ['shaft'],
                                             'position': [0.25], 'velocity': [0.0]}),
             ('std_msgs/msg/Float64MultiArray', {'data': [0.1, 0.7]}),
             ('std_msgs/msg/Float64', {'data': -2.0})]
    raw = to_cdr(items)
    assert [deserialize_message(raw[k], Float64).data for k in (0, 3)] == [1.5, -2.0]
    joint_state = deserialize_message(raw[1], JointState)
    assert (joint_state.name, list(joint_state.position)) == (['shaft'], [0.25])
    assert joint_state.header.stamp.sec == T0 // 1_000_000_000
    assert list(deserialize_message(raw[2], Float64MultiArray).data) == [0.1, 0.7]
    assert cdr_encoder('std_msgs/msg/Float64')({'data': -2.0}) == raw[3]
