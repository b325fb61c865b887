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

"""Replay schedule (ROS-free): original timing, rate, offset, loop, /clock ticks, remapping."""
import threading
import time

import pytest
from sma_actuator.bag.playback import parse_remappings, PlaybackOptions, Player, read_ahead
from sma_actuator.bag.reader import BagMessage

S = 1_000_000_000
BAG_START = 5_000 * S
# log times (s from bag start) of a small recording on two topics
LOG_S = [0.0, 0.010, 0.025, 0.5, 0.5, 1.2, 2.0]


def _messages(start_ns):
    for i, t in enumerate(LOG_S):
        log = BAG_START + int(t * S)
        if log >= start_ns:
            yield BagMessage('/a' if i % 2 else '/b', bytes([i]), log, log)


class FakeClock:
    """Monotonic time that jumps to each deadline instead of sleeping."""

    def __init__(self, start_ns=123 * S):
        self.now = start_ns
        self.start = start_ns

    def now_ns(self):
        return self.now

    def sleep_until(self, deadline, stop):
        self.now = max(self.now, deadline)
        return stop.is_set()


def _play(options, stop_after=None, clock=None):
    clock = clock or FakeClock()
    published, ticks = [], []
    stop = threading.Event()

    def publish(msg):
        published.append((clock.now - clock.start, msg))
        if stop_after is not None and len(published) >= stop_after:
            stop.set()

    player = Player(_messages, BAG_START, publish, options,
                    on_clock=lambda t: ticks.append((clock.now - clock.start, t)),
                    now_ns=clock.now_ns, sleep_until=clock.sleep_until)
    stats = player.run(stop)
    return published, ticks, stats


def test_messages_keep_their_original_spacing():
    published, _, stats = _play(PlaybackOptions())
    assert [wall for wall, _ in published] == [int(t * S) for t in LOG_S]
    assert [m.data for _, m in published] == [bytes([i]) for i in range(len(LOG_S))]
    assert stats.published == len(LOG_S) and stats.loops == 1 and not stats.stopped
    assert stats.lateness_ns == [0] * len(LOG_S)


@pytest.mark.parametrize('rate', [0.5, 2.0, 10.0])
def test_rate_scales_the_timeline(rate):
    published, _, _ = _play(PlaybackOptions(rate=rate))
    assert [wall for wall, _ in published] == [int(int(t * S) / rate) for t in LOG_S]


def test_start_offset_skips_earlier_messages_and_starts_at_once():
    published, _, _ = _play(PlaybackOptions(start_offset_s=0.5))
    assert [m.log_time_ns - BAG_START for _, m in published] == [
        int(t * S) for t in LOG_S if t >= 0.5]
    assert [wall for wall, _ in published] == [int((t - 0.5) * S) for t in LOG_S if t >= 0.5]


def test_loop_restarts_the_timeline_until_stopped():
    n = len(LOG_S)
    published, _, stats = _play(PlaybackOptions(loop=True), stop_after=2 * n + 3)
    assert [m.data for _, m in published] == [bytes([i % n]) for i in range(2 * n + 3)]
    walls = [wall for wall, _ in published]
    assert walls == sorted(walls)
    assert walls[n] == walls[n - 1], 'the next loop starts right after the last message'
    assert stats.loops == 2 and stats.stopped


def test_clock_ticks_report_bag_time_before_messages_due():
    published, ticks, _ = _play(PlaybackOptions(rate=2.0, clock_period_s=0.1))
    walls = [w for w, _ in ticks]
    assert walls == [int(k * 0.1 * S) for k in range(len(walls))]
    assert [t for _, t in ticks] == [BAG_START + int(2.0 * w) for w in walls]
    last_due = published[-1][0]
    assert walls[-1] <= last_due < walls[-1] + 0.1 * S


def test_stop_ends_playback_without_publishing_more():
    published, _, stats = _play(PlaybackOptions(), stop_after=3)
    assert len(published) == 3 and stats.stopped


def test_real_clock_waits_are_interrupted_by_stop():
    stop = threading.Event()
    stop.set()
    player = Player(_messages, BAG_START, lambda m: None, PlaybackOptions())
    assert player.run(stop).published == 0


@pytest.mark.parametrize('kwargs', [{'rate': 0}, {'rate': -1}, {'start_offset_s': -0.1},
                                    {'clock_period_s': 0}])
def test_bad_options_are_rejected(kwargs):
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        PlaybackOptions(**kwargs)


def test_remappings_are_parsed():
    assert parse_remappings(['/sma/joint_states:=/measured/joint_states', ' ', '/a := /b']) == {
        '/sma/joint_states': '/measured/joint_states', '/a': '/b'}


@pytest.mark.parametrize('entry', ['/a=/b', 'a:=/b', '/a:=b', '/a:='])
def test_bad_remappings_name_the_entry(entry):
    with pytest.raises(ValueError, match=f"bad remapping '{entry}'"):
        parse_remappings([entry])


def test_a_topic_cannot_be_remapped_twice():
    with pytest.raises(ValueError, match='remapped twice'):
        parse_remappings(['/a:=/b', '/a:=/c'])


def test_read_ahead_keeps_order_and_ends():
    stop = threading.Event()
    items = list(read_ahead(iter(range(1000)), stop, max_items=7))
    assert items == list(range(1000))


def test_read_ahead_passes_reader_errors_on():
    def broken():
        yield 1
        raise ValueError('chunk damaged')

    got = []
    with pytest.raises(ValueError, match='chunk damaged'):
        for item in read_ahead(broken(), threading.Event()):
            got.append(item)
    assert got == [1]


def test_read_ahead_reader_stops_with_the_consumer():
    produced = []

    def endless():
        i = 0
        while True:
            produced.append(i)
            yield i
            i += 1

    stop = threading.Event()
    for item in read_ahead(endless(), stop, max_items=3):
        if item == 5:
            break
    stop.set()
    time.sleep(0.3)  # give the reader thread time to notice
    count = len(produced)
    time.sleep(0.2)
    assert len(produced) == count <= 5 + 3 + 2
