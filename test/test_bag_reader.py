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

"""BagReader: bad input gives named errors; unfinished files are recovered, the loss reported."""
from mcap.reader import make_reader
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer as RosbagsWriter
from rosbags.typesys import get_typestore, Stores
from sma_actuator.bag.errors import (BagError, BagNotFoundError, NotMcapError,
                                     TruncatedBagError)
from sma_actuator.bag.reader import BagReader
from sma_actuator.bag.synthetic import to_cdr
from sma_actuator.bag.writer import BagWriter
import yaml

T0 = 1_600_000_000_000_000_000
DUTY = 'std_msgs/msg/Float64MultiArray'


def _write(path, count=300, **options):
    """Bag of ``count`` duty messages (distinct payloads); returns the payloads in order."""
    payloads = to_cdr([(DUTY, {'data': [i * 1e-3, 1.0]}) for i in range(count)])
    with BagWriter(path, chunk_size_bytes=1500, **options) as bag:
        bag.add_topic('/sma/duty', 'std_msgs/msg/Float64MultiArray')
        for i, data in enumerate(payloads):
            bag.write('/sma/duty', data, T0 + i * 1_000_000, T0 + i * 1_000_000 - 10)
    return payloads


@pytest.fixture
def mcap_file(tmp_path):
    payloads = _write(tmp_path / 'bag')
    return tmp_path / 'bag' / 'bag_0.mcap', payloads


def test_complete_bag_reads_every_message_with_times(mcap_file):
    path, payloads = mcap_file
    reader = BagReader(path.parent)
    assert reader.recoveries == []
    assert reader.profiles == ['ros2']
    info = reader.topics['/sma/duty']
    assert (info.type, info.message_count, info.serialization_format) == (
        'std_msgs/msg/Float64MultiArray', 300, 'cdr')
    msgs = list(reader.messages())
    assert [m.data for m in msgs] == payloads
    assert [m.log_time_ns - m.publish_time_ns for m in msgs] == [10] * 300
    assert list(reader.messages(start_time_ns=T0 + 250 * 1_000_000))[0].data == payloads[250]
    assert list(reader.messages(topics=['/other'])) == []
    assert reader.time_range_ns() == (T0, T0 + 299 * 1_000_000)


@pytest.mark.parametrize('fraction', [0.1, 0.33, 0.5, 0.77, 0.95])
def test_cut_file_recovers_a_prefix_and_reports_the_loss(mcap_file, tmp_path, fraction):
    path, payloads = mcap_file
    data = path.read_bytes()
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:int(len(data) * fraction)])
    reader = BagReader(cut)
    (report,) = reader.recoveries
    recovered = [m.data for m in reader.messages()]
    assert recovered == payloads[:len(recovered)], 'recovered data must be an exact prefix'
    assert report.recovered_messages == len(recovered) == reader.message_count
    assert report.file_size == cut.stat().st_size
    assert report.lost_bytes == report.file_size - report.recovered_bytes
    assert report.recovered_messages + report.lost_messages <= len(payloads)
    if fraction <= 0.5:  # inside the data section of this file
        assert report.lost_bytes > 0 and len(recovered) < len(payloads)
    assert f'recovered {len(recovered)} messages' in str(report) and str(cut) in str(report)


def test_cut_in_the_summary_loses_no_message(mcap_file, tmp_path):
    path, payloads = mcap_file
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(path.read_bytes()[:-30])
    reader = BagReader(cut)
    assert [m.data for m in reader.messages()] == payloads
    assert reader.recoveries[0].lost_bytes == 0


def _chunk_indexes(path):
    with open(path, 'rb') as f:
        return make_reader(f).get_summary().chunk_indexes


def test_damaged_chunk_is_skipped_and_later_chunks_kept(mcap_file, tmp_path):
    path, payloads = mcap_file
    chunks = _chunk_indexes(path)
    victim = chunks[len(chunks) // 2]
    data = bytearray(path.read_bytes())
    middle = victim.chunk_start_offset + victim.chunk_length // 2
    data[middle:middle + 8] = bytes(8)  # damage the compressed data of one chunk
    damaged = tmp_path / 'damaged.mcap'
    damaged.write_bytes(bytes(data[:chunks[-1].chunk_start_offset]))  # and cut the end
    reader = BagReader(damaged)
    recovered = [m.data for m in reader.messages()]
    # every message except those of the damaged chunk and of the cut-off last chunk
    times = [T0 + i * 1_000_000 for i in range(len(payloads))]
    assert recovered == [p for t, p in zip(times, payloads)
                         if not victim.message_start_time <= t <= victim.message_end_time
                         and t < chunks[-1].message_start_time]
    (report,) = reader.recoveries
    assert report.damage[0].offset == victim.chunk_start_offset
    assert f'at byte {victim.chunk_start_offset}' in str(report)


@pytest.mark.parametrize('compression', ['none', 'lz4', 'zstd'])
def test_messages_in_a_cut_chunk_are_counted_as_lost(tmp_path, compression):
    # lz4/zstd decode whole blocks only (64/128 KiB), so use chunks of several blocks
    size = 1500 if compression == 'none' else 400_000
    payloads = to_cdr([(DUTY, {'data': [i * 1e-3, 1.0]}) for i in range(12000)])
    with BagWriter(tmp_path / 'bag', chunk_size_bytes=size, compression=compression) as bag:
        bag.add_topic('/sma/duty', 'std_msgs/msg/Float64MultiArray')
        for i, data in enumerate(payloads):
            bag.write('/sma/duty', data, T0 + i)
    full = tmp_path / 'bag' / 'bag_0.mcap'
    second = _chunk_indexes(full)[1]
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(full.read_bytes()[:second.chunk_start_offset + int(second.chunk_length * .9)])
    reader = BagReader(cut)
    (report,) = reader.recoveries
    in_first_chunk = sum(1 for m in reader.messages())
    assert report.recovered_messages == in_first_chunk
    assert 0 < report.lost_messages < len(payloads) - in_first_chunk
    assert report.lost_bytes > 0.8 * second.chunk_length


@pytest.mark.parametrize('content, error, problem', [
    (b'', TruncatedBagError, 'empty'),
    (b'\x89MCA', TruncatedBagError, 'inside the MCAP magic'),
    (b'\x89MCAP0\r\n\x01\x10', TruncatedBagError, 'before the MCAP header'),
    (b'time,position\n0,0\n', NotMcapError, 'not an MCAP file'),
    (b'#ROSBAG V2.0\n' + bytes(100), NotMcapError, 'not an MCAP file'),
])
def test_bad_files_raise_named_errors(tmp_path, content, error, problem):
    path = tmp_path / 'x.mcap'
    path.write_bytes(content)
    with pytest.raises(error, match=problem) as info:
        BagReader(path)
    assert str(path) in str(info.value)
    assert isinstance(info.value, ValueError)


def test_missing_paths_raise_named_errors(tmp_path):
    with pytest.raises(BagNotFoundError, match='no such file'):
        BagReader(tmp_path / 'nope')
    (tmp_path / 'empty_dir').mkdir()
    with pytest.raises(BagNotFoundError, match='no .mcap file'):
        BagReader(tmp_path / 'empty_dir')


def test_metadata_listing_a_missing_file_is_reported(mcap_file):
    path, _ = mcap_file
    meta = path.parent / 'metadata.yaml'
    info = yaml.safe_load(meta.read_text())
    info['rosbag2_bagfile_information']['relative_file_paths'].append('bag_1.mcap')
    meta.write_text(yaml.safe_dump(info))
    with pytest.raises(BagNotFoundError, match=r"missing files: \['bag_1.mcap'\]"):
        BagReader(path.parent)


def test_broken_metadata_yaml_is_reported(mcap_file):
    path, _ = mcap_file
    (path.parent / 'metadata.yaml').write_text('just: [unclosed')
    with pytest.raises(BagError, match='cannot read rosbag2 metadata'):
        BagReader(path.parent)


def test_directory_without_metadata_reads_files_in_split_order(tmp_path, monkeypatch):
    monkeypatch.setattr('sma_actuator.bag.writer.MIN_FILE_SIZE_BYTES', 1000)  # small files
    payloads = _write(tmp_path / 'b', count=200, max_file_size_bytes=3000)
    (tmp_path / 'b' / 'metadata.yaml').unlink()  # as after a crash
    reader = BagReader(tmp_path / 'b')
    assert len(reader.files) > 2
    assert [m.data for m in reader.messages()] == payloads


def test_reads_a_rosbag2_bag_written_by_an_independent_writer(tmp_path):
    """The rosbags rosbag2 writer (version 9 metadata, own MCAP writer) stands in for rosbag2."""
    store = get_typestore(Stores.ROS2_JAZZY)
    Float64 = store.types['std_msgs/msg/Float64']
    path = tmp_path / 'rosbag2_bag'
    sent = []
    with RosbagsWriter(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection('/sma/setpoint', Float64.__msgtype__, typestore=store)
        for i in range(50):
            raw = bytes(store.serialize_cdr(Float64(data=i * 0.5), Float64.__msgtype__))
            writer.write(conn, T0 + i, raw)
            sent.append(raw)
    reader = BagReader(path)
    assert reader.topics['/sma/setpoint'].type == 'std_msgs/msg/Float64'
    assert reader.topics['/sma/setpoint'].schema_encoding == 'ros2msg'
    assert [m.data for m in reader.messages()] == sent


# --- issue 13: integrity checks, loss report, metadata.yaml trust ----------------------------
def test_one_flipped_bit_in_a_chunk_of_a_complete_bag_is_reported_not_read(mcap_file):
    path, payloads = mcap_file
    victim = _chunk_indexes(path)[2]
    data = bytearray(path.read_bytes())
    data[victim.chunk_start_offset + victim.chunk_length - 5] ^= 0x10  # in the compressed data
    path.write_bytes(bytes(data))
    reader = BagReader(path.parent)
    got = [m.data for m in reader.messages()]
    times = [T0 + i * 1_000_000 for i in range(len(payloads))]
    assert got == [p for t, p in zip(times, payloads)
                   if not victim.message_start_time <= t <= victim.message_end_time]
    (report,) = reader.recoveries
    lost = len(payloads) - len(got)
    assert report.lost_exact and report.lost_messages == lost > 0
    assert report.lost_by_topic == {'/sma/duty': lost}
    assert report.lost_seconds == pytest.approx((lost - 1) * 1e-3)
    assert f'lost {lost} messages (/sma/duty {lost})' in str(report)
    assert f'at byte {victim.chunk_start_offset}' in str(report)


def test_cut_bag_with_metadata_reports_the_exact_loss(mcap_file):
    path, payloads = mcap_file
    path.write_bytes(path.read_bytes()[:len(path.read_bytes()) // 2])
    reader = BagReader(path.parent)
    (report,) = reader.recoveries
    got = sum(1 for _ in reader.messages())
    assert report.lost_exact and report.lost_messages == len(payloads) - got > 0
    assert 'holding at least 0' not in str(report) and report.lost_seconds > 0


@pytest.mark.parametrize('paths', [None, 5, [None], [1, 2], 'bag_0.mcap', ['bag_0.mcap'] * 2])
def test_metadata_paths_of_the_wrong_type_are_a_bag_error(mcap_file, paths):
    path, _ = mcap_file
    meta = path.parent / 'metadata.yaml'
    info = yaml.safe_load(meta.read_text())
    info['rosbag2_bagfile_information']['relative_file_paths'] = paths
    meta.write_text(yaml.safe_dump(info))
    if paths is None:
        assert BagReader(path.parent).message_count == 300  # absent: the directory's files
        return
    with pytest.raises(BagError, match='relative_file_paths must be'):
        BagReader(path.parent)


def test_metadata_paths_leaving_the_bag_are_rejected(mcap_file, tmp_path):
    path, _ = mcap_file
    other = tmp_path / 'other'
    _write(other, count=5)
    meta = path.parent / 'metadata.yaml'
    info = yaml.safe_load(meta.read_text())
    (path.parent / 'link_0.mcap').symlink_to(other / 'other_0.mcap')
    for rel in (str(other / 'other_0.mcap'), '../other/other_0.mcap', 'link_0.mcap'):
        info['rosbag2_bagfile_information']['relative_file_paths'] = [rel]
        info['rosbag2_bagfile_information'].pop('files', None)
        meta.write_text(yaml.safe_dump(info))
        with pytest.raises(BagError, match='outside the bag directory'):
            BagReader(path.parent)


@pytest.mark.parametrize('text, problem', [
    ('a: ' + '[' * 100_000 + ']' * 100_000, 'nested deeper than 32'),
    ('# ' + 'x' * (5 << 20), 'over the limit'),
    ('rosbag2_bagfile_information:\n  files: [{path: bag_0.mcap, message_count: x}]\n',
     r'files\[0\].message_count must be'),
])
def test_hostile_metadata_yaml_is_a_bag_error(mcap_file, text, problem):
    path, _ = mcap_file
    (path.parent / 'metadata.yaml').write_text(text)
    with pytest.raises(BagError, match=problem):
        BagReader(path.parent)
