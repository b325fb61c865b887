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
Cost of a bag split against the number of files already written (issue 13 item 9).

Writes 10 KiB messages into a bag that splits at the smallest allowed file size (64 KiB,
about 6 messages per file) and prints the mean time per split for the first and the last
block of splits. A constant cost gives about the same figure for both.

    python benchmarks/bench_bag_split.py               # 600 files
    python benchmarks/bench_bag_split.py --files 2000
"""
import argparse
from pathlib import Path
import tempfile
import time

from sma_actuator.bag import writer as writer_module
from sma_actuator.bag.writer import BagWriter

T0 = 1_700_000_000_000_000_000


def main():
    """Write the bag, time every split, print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--files', type=int, default=600, help='files to write (default 600)')
    args = parser.parse_args()
    payload = bytes(range(256)) * 40
    split_times = []
    split = BagWriter._split

    def timed_split(self):
        start = time.perf_counter()
        split(self)
        split_times.append(time.perf_counter() - start)
    BagWriter._split = timed_split
    with tempfile.TemporaryDirectory() as tmp:
        with BagWriter(Path(tmp) / 'bag', compression='none', chunk_size_bytes=16384,
                       max_file_size_bytes=writer_module.MIN_FILE_SIZE_BYTES) as bag:
            bag.add_topic('/sma/blob', 'std_msgs/msg/UInt8MultiArray', definition='uint8[] data',
                          type_hash='RIHS01_' + '0' * 64)
            i = 0
            while len(split_times) < args.files - 1:
                bag.write('/sma/blob', payload, T0 + i * 1000)
                i += 1
        block = max(1, len(split_times) // 10)
        first = sum(split_times[:block]) / block
        last = sum(split_times[-block:]) / block
        print(f'{len(split_times) + 1} files, {i} messages of {len(payload)} B: mean split '
              f'{first * 1e3:.2f} ms over the first {block} splits, {last * 1e3:.2f} ms over '
              f'the last {block} (ratio {last / first:.2f})')


if __name__ == '__main__':
    main()
