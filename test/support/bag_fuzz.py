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
Mutate recorder bags for the fuzz tests: truncations, bit flips, zeroed ranges, metadata edits.

Every mutation is drawn from a ``random.Random`` so a seed replays a case exactly.
"""
import contextlib
import os
from pathlib import Path
import shutil
import signal
import struct

from sma_actuator.bag.synthetic import write_demo_run
import yaml

_HEAD = struct.Struct('<BQ')
#: Recorder bags the fuzzers start from: name -> BagWriter options.
SOURCES = {
    'zstd': {'compression': 'zstd', 'chunk_size_bytes': 2048},
    'lz4': {'compression': 'lz4', 'chunk_size_bytes': 2048},
    'none': {'compression': 'none', 'chunk_size_bytes': 2048},
    'split': {'compression': 'zstd', 'chunk_size_bytes': 2048, 'max_file_duration_s': 0.75},
    'one_chunk': {'compression': 'zstd'},
}
MCAP_KINDS = ('truncate', 'bitflip', 'zero')
_LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
_DUMPER = getattr(yaml, 'CSafeDumper', yaml.SafeDumper)


class CaseTimeout(Exception):
    """A fuzz case ran longer than its time bound."""


@contextlib.contextmanager
def time_limit(seconds):
    """Raise `CaseTimeout` in the main thread if the block runs longer than `seconds`."""
    def _expired(signum, frame):
        raise CaseTimeout(f'case still running after {seconds} s')
    old = signal.signal(signal.SIGALRM, _expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def make_sources(root):
    """Write one demo recording per entry of `SOURCES`; return name -> bag directory."""
    out = {}
    for name, options in SOURCES.items():
        out[name] = write_demo_run(Path(root) / name, duration_s=1.5, chunk_max_age_s=0.0,
                                   **options)
    return out


def record_starts(data):
    """Offsets of the top-level records of an intact MCAP file (magic skipped)."""
    starts, pos = [], 8
    while pos + _HEAD.size <= len(data) - 8:
        starts.append(pos)
        pos += _HEAD.size + _HEAD.unpack_from(data, pos)[1]
    return starts


def _position(rng, data, starts):
    """Half uniform, half within 48 bytes after a record start (opcodes, lengths, CRCs)."""
    if rng.random() < 0.5 or not starts:
        return rng.randrange(len(data))
    return min(len(data) - 1, rng.choice(starts) + rng.randrange(48))


def mutate_mcap(rng, data, kind):
    """Return (mutated bytes, description) for one MCAP mutation of `kind`."""
    starts = record_starts(data)
    out = bytearray(data)
    if kind == 'truncate':
        cut = rng.randrange(len(data))
        return bytes(out[:cut]), f'cut at {cut} of {len(data)} bytes'
    if kind == 'bitflip':
        flips = [(_position(rng, data, starts), rng.randrange(8))
                 for _ in range(rng.choice((1, 1, 1, 2, 4, 8)))]
        for pos, bit in flips:
            out[pos] ^= 1 << bit
        return bytes(out), f'bit flips (byte, bit) {flips}'
    start = _position(rng, data, starts)
    length = rng.choice((1, 2, 4, 8, 16, 64, 256, 1024))
    out[start:start + length] = bytes(len(out[start:start + length]))
    return bytes(out), f'zeroed {length} bytes at {start}'


def _set_paths(info, paths):
    info['relative_file_paths'] = paths
    return info


def mutate_metadata(rng, text, bag_dir, other_bag):
    """Return (new metadata.yaml text or None to delete it, description); may add a symlink."""
    choice = rng.randrange(16)
    info = yaml.load(text, Loader=_LOADER)
    inner = info['rosbag2_bagfile_information']

    def dump(data):
        return yaml.dump(data, Dumper=_DUMPER)
    other = sorted(Path(other_bag).glob('*.mcap'))[0]
    if choice == 0:
        cut = rng.randrange(len(text))
        return text[:cut], f'metadata cut at {cut}'
    if choice == 1:
        raw = bytearray(text.encode())
        flips = [(rng.randrange(len(raw)), rng.randrange(7)) for _ in range(rng.choice((1, 2)))]
        for pos, bit in flips:
            raw[pos] ^= 1 << bit
        return raw.decode('utf-8', 'replace'), f'metadata bit flips {flips}'
    if choice == 2:
        _set_paths(inner, [str(other.resolve())])
        return dump(info), 'absolute path to another bag'
    if choice == 3:
        _set_paths(inner, [f'../{other.parent.name}/{other.name}'])
        return dump(info), 'relative path escaping the bag'
    if choice == 4:
        value = rng.choice((None, 5, 'x.mcap', [None], [1, 2], [{'a': 1}], {'a': 'b'}, [[]]))
        _set_paths(inner, value)
        return dump(info), f'relative_file_paths = {value!r}'
    if choice == 5:
        depth = rng.choice((200, 5000, 100000))
        return (text.replace('relative_file_paths:', 'relative_file_paths: ' + '[' * depth
                             + ']' * depth + '\nunused:', 1), f'nested {depth} deep')
    if choice == 6:
        link = Path(bag_dir) / 'link_0.mcap'
        with contextlib.suppress(FileExistsError):
            os.symlink(other.resolve(), link)
        _set_paths(inner, [link.name])
        return dump(info), 'symlink out of the bag'
    if choice == 7:
        paths = inner['relative_file_paths']
        _set_paths(inner, paths + paths[:1])
        return dump(info), 'a path listed twice'
    if choice == 8:
        return None, 'metadata.yaml deleted'
    if choice == 9:
        field = rng.choice(('message_count', 'path', 'starting_time', 'duration'))
        inner['files'][0][field] = rng.choice((None, 'x', -5, [1], 10 ** 30))
        return dump(info), f'files[0].{field} changed'
    if choice == 10:
        inner['topics_with_message_count'][0]['message_count'] = rng.choice((0, 10 ** 9, 'x'))
        return dump(info), 'topic message count changed'
    if choice == 11:
        inner['files'] = rng.choice((None, 5, [None], 'x'))
        return dump(info), 'files replaced'
    if choice == 12:
        return text + '\n# ' + 'x' * (9 << 20) + '\n', 'metadata over 8 MiB'
    if choice == 13:
        return ('a: &a [1, 2]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\n'
                'c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]\n' + text), 'alias expansion'
    if choice == 14:
        return text.replace('rosbag2_bagfile_information', 'other', 1), 'root key renamed'
    info['rosbag2_bagfile_information'] = rng.choice((None, 7, [1], 'x'))
    return dump(info), 'root replaced'


def copy_bag(source, target):
    """Replace `target` with a copy of the bag directory `source`."""
    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(source, target, symlinks=True)
    return target


def mutate_bag(rng, source, target, other_bag, kind):
    """Copy bag `source` to `target` and apply one mutation of `kind`; return its description."""
    copy_bag(source, target)
    if kind == 'metadata':
        meta = target / 'metadata.yaml'
        text, what = mutate_metadata(rng, meta.read_text(), target, other_bag)
        if text is None:
            meta.unlink()
        else:
            meta.write_text(text, encoding='utf-8', errors='replace')
        return what
    victim = rng.choice(sorted(target.glob('*.mcap')))
    data, what = mutate_mcap(rng, victim.read_bytes(), kind)
    victim.write_bytes(data)
    return f'{victim.name}: {what}'
