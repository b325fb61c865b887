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
Replay timing without ROS: when each stored message is due, at a rate, from an offset, looped.

A message logged at bag time ``t`` is due at wall time
``wall_start + (t - (bag_start + start_offset)) / rate``; with ``loop`` the timeline restarts
after the last message. Optional clock ticks report the bag time every ``clock_period_s`` of wall
time (for ``/clock``). Time is read and waited on through injected functions, so the schedule is
tested with a fake clock and the node uses the monotonic clock.
"""
from dataclasses import dataclass, field
import queue
import threading
import time
from typing import Callable, Dict, Iterable, Iterator, List, Optional

from .reader import BagMessage

_NS = 1_000_000_000


def parse_remappings(entries: Iterable[str]) -> Dict[str, str]:
    """
    Parse ``'/from:=/to'`` entries into ``{'/from': '/to'}``.

    :raises ValueError: An entry without ``:=``, a relative name, or a topic mapped twice.
    """
    mapping: Dict[str, str] = {}
    for entry in entries:
        if not entry or not entry.strip():
            continue
        source, sep, target = (part.strip() for part in entry.partition(':='))
        if not sep or not source.startswith('/') or not target.startswith('/'):
            raise ValueError(f"bad remapping '{entry}': expected '/from/topic:=/to/topic'")
        if source in mapping:
            raise ValueError(f"topic '{source}' is remapped twice")
        mapping[source] = target
    return mapping


def read_ahead(messages: Iterable[BagMessage], stop: threading.Event,
               max_items: int = 5000) -> Iterator[BagMessage]:
    """
    Iterate ``messages`` through a background thread that reads up to ``max_items`` ahead.

    Reading a bag goes chunk by chunk (decompress, parse thousands of records at once); done
    inline it would hold up every message due meanwhile. The reader thread stops when the
    consumer stops iterating or ``stop`` is set; its exceptions are re-raised here.
    """
    items: queue.Queue = queue.Queue(maxsize=max_items)
    done = object()
    quit_reader = threading.Event()

    def fill() -> None:
        try:
            for msg in messages:
                while not (stop.is_set() or quit_reader.is_set()):
                    try:
                        items.put(msg, timeout=0.1)
                        break
                    except queue.Full:
                        continue
                else:
                    return
            items.put(done)
        except Exception as err:  # noqa: BLE001 - handed to the consumer below
            items.put(err)

    reader = threading.Thread(target=fill, name='bag-read-ahead', daemon=True)
    reader.start()
    try:
        while True:
            item = items.get()
            if item is done:
                return
            if isinstance(item, Exception):
                raise item
            yield item
    finally:
        quit_reader.set()


@dataclass
class PlaybackOptions:
    """How to play: rate factor (>0), loop, start offset [s] into the bag, /clock period [s]."""

    rate: float = 1.0
    loop: bool = False
    start_offset_s: float = 0.0
    clock_period_s: Optional[float] = None

    def __post_init__(self) -> None:
        if not self.rate > 0:
            raise ValueError(f'rate must be > 0, got {self.rate}')
        if self.start_offset_s < 0:
            raise ValueError(f'start_offset_s must be >= 0, got {self.start_offset_s}')
        if self.clock_period_s is not None and not self.clock_period_s > 0:
            raise ValueError(f'clock_period_s must be > 0, got {self.clock_period_s}')


@dataclass
class PlaybackStats:
    """What a playback did: messages published, loops finished, lateness [ns] per message."""

    published: int = 0
    loops: int = 0
    lateness_ns: List[int] = field(default_factory=list)
    stopped: bool = False


class Player:
    """
    Publish a bag's messages on schedule.

    :param messages: ``messages(start_time_ns)`` returns the messages to play from that bag
        time on, in log-time order (e.g. ``BagReader.messages`` with a topic filter).
    :param bag_start_ns: Log time of the bag's first message [ns].
    :param publish: Called with each :class:`BagMessage` when it is due.
    :param options: :class:`PlaybackOptions`.
    :param on_clock: Called with the bag time [ns] at each clock tick (if clock_period_s).
    :param now_ns: Monotonic time source [ns].
    :param sleep_until: ``sleep_until(deadline_ns, stop)`` waits; returns True if stopped.
    """

    def __init__(self, messages: Callable[[int], Iterable[BagMessage]], bag_start_ns: int,
                 publish: Callable[[BagMessage], None], options: PlaybackOptions, *,
                 on_clock: Optional[Callable[[int], None]] = None,
                 now_ns: Callable[[], int] = time.monotonic_ns,
                 sleep_until: Optional[Callable[[int, threading.Event], bool]] = None) -> None:
        self._messages = messages
        self._start_ns = bag_start_ns + int(round(options.start_offset_s * _NS))
        self._publish = publish
        self._options = options
        self._on_clock = on_clock if options.clock_period_s else None
        self._now_ns = now_ns
        self._sleep_until = sleep_until or self._wait
        self.stats = PlaybackStats()

    def _wait(self, deadline_ns: int, stop: threading.Event) -> bool:
        while True:
            remaining = deadline_ns - self._now_ns()
            if remaining <= 0:
                return stop.is_set()
            if stop.wait(remaining / _NS):
                return True

    def bag_time_ns(self, wall_ns: int, wall_start_ns: int) -> int:
        """Return the bag time [ns] that wall time ``wall_ns`` corresponds to."""
        return self._start_ns + int((wall_ns - wall_start_ns) * self._options.rate)

    def run(self, stop: threading.Event) -> PlaybackStats:
        """Play (until the end, or forever with loop) unless ``stop`` is set; return stats."""
        period_ns = int(self._options.clock_period_s * _NS) if self._on_clock else None
        while not stop.is_set():
            wall_start = self._now_ns()
            next_tick = wall_start
            played_any = False
            for msg in read_ahead(self._messages(self._start_ns), stop):
                due = wall_start + int((msg.log_time_ns - self._start_ns) / self._options.rate)
                while period_ns is not None and next_tick <= due:
                    if self._sleep_until(next_tick, stop):
                        break
                    self._on_clock(self.bag_time_ns(next_tick, wall_start))
                    next_tick += period_ns
                if self._sleep_until(due, stop):
                    self.stats.stopped = True
                    return self.stats
                self.stats.lateness_ns.append(self._now_ns() - due)
                self._publish(msg)
                self.stats.published += 1
                played_any = True
            self.stats.loops += 1
            if not (self._options.loop and played_any):
                break
        self.stats.stopped = stop.is_set()
        return self.stats
