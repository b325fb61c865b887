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
replay node: play a bag with its original timing (docs/recording.md).

Publishes the stored CDR bytes (no re-serialisation) of each selected topic, on the topic name
after ``remap``, with the QoS the original publishers offered (as rosbag2 play). Timing,
rate, loop and start offset come from :class:`sma_actuator.bag.playback.Player`; with
``clock`` it also publishes ``/clock`` so other nodes can run on sim time.

Safety: when playback ends, is stopped or interrupted, and the duty topic was being played,
the node publishes duty ``[0, 0]`` on it, so a replay never leaves a wire heated.

Run: ``replay --ros-args -p bag_path:=runs/step1/bag -p rate:=2.0
-p "remap:=['/sma/joint_states:=/measured/joint_states']"``
"""
import queue
import sys
import threading
import time
from typing import Any, Dict, List, Optional, Sequence

from builtin_interfaces.msg import Time
import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sma_actuator.bag.errors import BagError, UnknownTypeError
from sma_actuator.bag.playback import parse_remappings, PlaybackOptions, PlaybackStats, Player
from sma_actuator.bag.qos import adapt_offer_to_recorded_offers, load_offered_qos_profiles
from sma_actuator.bag.reader import BagMessage, BagReader
from sma_actuator.nodes.ros_bag import message_class, qos_profile
from sma_actuator.nodes.ros_console import (
    create_node,
    handle_command_line,
    init_with_stop_signals,
    spin_until_stopped,
)
from sma_actuator.nodes.ros_diagnostics import Diagnostics, ERROR, OK
from sma_actuator.nodes.ros_params import declare_parameters, overrides_from_kwargs, Param
from std_msgs.msg import Float64MultiArray

PARAMETERS = (
    Param('bag_path', '', 'Bag directory or .mcap file to play (required)'),
    Param('rate', 1.0, 'Speed factor: 2.0 plays twice as fast', (0.01, 100.0)),
    Param('loop', False, 'Start again after the last message'),
    Param('start_offset_s', 0.0, 'Skip this much bag time from the start [s]', (0.0, 1e6)),
    Param('topics', None, 'Topics to play; unset: all in the bag', kind='string_array'),
    Param('remap', None, "Topic remappings, entries '/from:=/to'", kind='string_array'),
    Param('clock', False, 'Publish /clock (rosgraph_msgs/Clock) with the bag time'),
    Param('follow_clock', False, 'Lockstep with a node that owns /clock (plant_sim '
          'accelerated lockstep): on each /clock tick publish what is due by then (bag time '
          'counted from the first tick) and the last duty again if none is, instead of '
          'playing on the wall clock'),
    Param('clock_frequency_hz', 100.0, 'Rate of /clock messages [Hz]', (1.0, 1000.0)),
    Param('wait_for_subscribers_s', 10.0, 'Before the first message, wait at most this long '
          'for the required_subscribers (else every played topic) [s]', (0.0, 600.0)),
    Param('required_subscribers', None, 'Published topics that must be matched before '
          'playback starts, else no playback and exit 1; unset: the duty topic when played, '
          'and /clock with clock', kind='string_array'),
    Param('zero_duty_on_stop', True, 'On end/stop publish duty [0, 0] on the (remapped) duty '
          'topic'),
    Param('duty_topic', '/sma/duty', 'Bag topic that carries the duty commands'),
    Param('diagnostics_period_s', 1.0, 'Publish /diagnostics every this many seconds [s]',
          (0.1, 60.0)),
)
DUTY_TYPE = 'std_msgs/msg/Float64MultiArray'
# hold after the required subscribers matched, before the first message [s] (discovery
# matches the two ends one after the other: see _wait_for_subscribers)
SETTLE_S = 0.5


class ReplayNode(Node):
    """
    Play a bag; call :meth:`start`, watch :attr:`finished`, :meth:`stop` to abort.

    :param context: rclpy context (tests, embedding); default: the global one.
    :param params: Parameter values by name (same names as config/replay.yaml).
    :raises BagError: The bag cannot be read, or asked-for topics are not in it.
    :raises ValueError: Unknown parameter, bad remapping or option.
    """

    def __init__(self, *, context: Optional[Context] = None, node_name: str = 'replay',
                 **params: Any) -> None:
        super().__init__(node_name, context=context,
                         parameter_overrides=overrides_from_kwargs(PARAMETERS, params))
        p = declare_parameters(self, PARAMETERS)
        if not p['bag_path']:
            raise ValueError('bag_path is required: the bag directory or .mcap file to play')
        self._reader = BagReader(p['bag_path'])
        for report in self._reader.recoveries:
            self.get_logger().warning(str(report))
        remap = parse_remappings(p['remap'] or [])
        self._topic_out = {}
        self._replay_pubs = {}
        for topic in self._select(p['topics'] or []):
            self._topic_out[topic] = remap.get(topic, topic)
            self._replay_pubs[topic] = self._publisher_for(topic, self._topic_out[topic])
        for source in sorted(set(remap) - set(self._topic_out)):
            self.get_logger().warning(f"remapping of '{source}' unused: topic not played")
        self._duty_topic = p['duty_topic'] if p['zero_duty_on_stop'] else None
        if self._duty_topic in self._topic_out and \
                self._reader.topics[self._duty_topic].type != DUTY_TYPE:
            raise UnknownTypeError(self._reader.path, f"duty topic '{self._duty_topic}' is not "
                                                      f'{DUTY_TYPE}; cannot zero it on stop')
        self._follow = p['follow_clock']
        if self._follow and (p['clock'] or p['loop'] or p['rate'] != 1.0):
            raise ValueError('follow_clock takes the time from /clock: it excludes clock, loop '
                             'and rate')
        self._ticks = queue.Queue()
        if self._follow:
            self.create_subscription(Clock, '/clock', lambda m: self._ticks.put(
                m.clock.sec * 1_000_000_000 + m.clock.nanosec),
                QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
        options = PlaybackOptions(
            rate=p['rate'], loop=p['loop'], start_offset_s=p['start_offset_s'],
            clock_period_s=1.0 / p['clock_frequency_hz'] if p['clock'] else None)
        self._clock_pub = self.create_publisher(
            Clock, '/clock', QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)) \
            if p['clock'] else None
        topics = sorted(self._topic_out)
        if not topics:
            raise BagError(self._reader.path, 'nothing to play: no topic with messages of an '
                                              f'installed type (bag topics: '
                                              f'{sorted(self._reader.topics)})')
        self._topics = topics
        messages = self._reader.messages(topics)
        first = next(messages)  # the timeline (and start_offset_s) starts at the first played
        messages.close()
        self._player = Player(lambda start: self._reader.messages(topics, start),
                              first.log_time_ns, self._publish, options,
                              on_clock=self._publish_clock)
        self._wait_s = p['wait_for_subscribers_s']
        self._start_ns = first.log_time_ns + int(p['start_offset_s'] * 1e9)
        published = {self._topic_out[t]: pub for t, pub in self._replay_pubs.items()}
        if self._clock_pub is not None:
            published['/clock'] = self._clock_pub
        required = p['required_subscribers']
        if required is None:
            required = [self._topic_out[t] for t in (p['duty_topic'],) if t in self._topic_out]
            required += ['/clock'] if p['clock'] else []
        unknown = sorted(set(required) - set(published))
        if unknown:
            raise ValueError(f'required_subscribers {unknown} are not published (published: '
                             f'{sorted(published)})')
        self._required = {name: published[name] for name in required}
        self._published = published
        self._stop_event = threading.Event()
        self._zeroed = threading.Lock()
        self._zero_sent = False
        self._error = None
        self.finished = threading.Event()
        self._worker = None
        self._diag = Diagnostics(self, 'replay')
        self.create_timer(p['diagnostics_period_s'], self._publish_diagnostics)
        self.get_logger().info(f'playing {topics} from {self._reader.path} at rate '
                               f"{p['rate']}" + (f', remapped {remap}' if remap else ''))

    def _select(self, wanted: List[str]) -> List[str]:
        topics = self._reader.topics
        missing = sorted(set(wanted) - set(topics))
        if missing:
            raise BagError(self._reader.path, f'topics {missing} are not in the bag; it holds '
                                              f'{sorted(topics)}')
        selected = []
        for name in (wanted or sorted(topics)):
            info = topics[name]
            problem = None
            if info.serialization_format != 'cdr':
                problem = f"is stored as '{info.serialization_format}', not cdr"
            else:
                try:
                    message_class(info.type)
                except UnknownTypeError as err:
                    problem = err.problem
            if problem and wanted:
                raise UnknownTypeError(self._reader.path, f"topic '{name}' {problem}")
            if problem:
                self.get_logger().warning(f"skipping '{name}': {problem}")
            elif info.message_count:
                selected.append(name)
        return selected

    def _publisher_for(self, topic: str, out_name: str) -> Publisher:
        info = self._reader.topics[topic]
        try:
            offers = load_offered_qos_profiles(info.offered_qos_profiles)
        except ValueError as err:
            self.get_logger().warning(f"'{topic}': unreadable recorded QoS ({err}); "
                                      'publishing reliable')
            offers = []
        offer = adapt_offer_to_recorded_offers(offers)
        return self.create_publisher(message_class(info.type), out_name,
                                     qos_profile(offer['reliability'], offer['durability'], 100))

    @property
    def played_topics(self) -> Dict[str, str]:
        """Bag topic -> published topic name."""
        return dict(self._topic_out)

    @property
    def stats(self) -> PlaybackStats:
        """Return the player's :class:`~sma_actuator.bag.playback.PlaybackStats` so far."""
        return self._player.stats

    def start(self) -> None:
        """Start playback in a background thread (see ``wait_for_subscribers_s``)."""
        if self._worker is None:
            self._worker = threading.Thread(target=self._run, name='replay', daemon=True)
            self._worker.start()

    def _wait_for_subscribers(self) -> bool:
        """
        Wait until the required topics (else every played topic) are matched.

        Returns False if stopped meanwhile. Raises RuntimeError when a required topic is
        still unmatched after wait_for_subscribers_s: playing into nothing is not a replay.
        Once matched it holds SETTLE_S more (publishing the start time on /clock), because
        our publisher matching the subscriber does not mean the subscriber matched us yet.
        """
        waiting = self._required or self._published
        deadline = time.monotonic() + self._wait_s
        while not all(pub.get_subscription_count() for pub in waiting.values()):
            if time.monotonic() > deadline or self._stop_event.wait(0.05):
                break
        missing = sorted(n for n, pub in self._required.items()
                         if not pub.get_subscription_count())
        if missing and not self._stop_event.is_set():
            raise RuntimeError(f'no subscriber on {missing} within {self._wait_s:g} s '
                               '(wait_for_subscribers_s): not playing')
        lonely = sorted(n for n, pub in self._published.items()
                        if not pub.get_subscription_count())
        if lonely:
            self.get_logger().warning(f'starting with no subscriber on {lonely}')
        settle_end = time.monotonic() + (SETTLE_S if self._required else 0.0)
        while time.monotonic() < settle_end:
            if self._clock_pub is not None:
                self._publish_clock(self._start_ns)
            if self._stop_event.wait(0.05):
                break
        return not self._stop_event.is_set()

    def _run(self) -> None:
        try:
            if self._wait_for_subscribers():
                if self._follow:
                    self._follow_clock()
                else:
                    self._player.run(self._stop_event)
        except Exception as err:  # noqa: BLE001 - report, make safe, never die silently
            self._error = err
            self.get_logger().error(f'playback failed: {err}')
        finally:
            self._send_zero_duty()
            self.finished.set()

    def _follow_clock(self) -> None:
        """Publish on each /clock tick what is due by its bag time; see follow_clock."""
        deadline = time.monotonic() + self._wait_s
        while not self.count_publishers('/clock'):
            if time.monotonic() > deadline:
                raise RuntimeError(f'no /clock publisher within {self._wait_s:g} s: nothing '
                                   'to follow')
            if self._stop_event.wait(0.05):
                return
        # of the ticks queued while waiting only the newest is live: the plant in lockstep
        # waits at it for a reply (one reply per tick, else the steps slip)
        while self._ticks.qsize() > 1:
            self._ticks.get_nowait()
        messages = self._reader.messages(self._topics)
        pending = next(messages, None)
        first_tick, last_duty = None, None
        while pending is not None and not self._stop_event.is_set():
            try:
                tick = self._ticks.get(timeout=0.05)
            except queue.Empty:
                continue
            first_tick = tick if first_tick is None else first_tick
            due = self._start_ns + (tick - first_tick)
            duty_sent = False
            while pending is not None and pending.log_time_ns <= due:
                self._publish(pending)
                self._player.stats.published += 1
                if pending.topic == self._duty_topic:
                    last_duty, duty_sent = pending, True
                pending = next(messages, None)
            if not duty_sent and last_duty is not None:
                self._publish(last_duty)   # the plant in lockstep waits for a reply per step
        if first_tick is not None:
            self.get_logger().info(f'followed /clock from {first_tick * 1e-9:.3f} s = bag time '
                                   f'{self._start_ns * 1e-9:.3f} s')

    def _publish(self, msg: BagMessage) -> None:
        self._replay_pubs[msg.topic].publish(msg.data)

    def _publish_clock(self, bag_time_ns: int) -> None:
        sec, nanosec = divmod(bag_time_ns, 1_000_000_000)
        self._clock_pub.publish(Clock(clock=Time(sec=sec, nanosec=nanosec)))

    def _send_zero_duty(self) -> None:
        with self._zeroed:
            if self._zero_sent or self._duty_topic not in self._replay_pubs:
                return
            self._zero_sent = True
            pub = self._replay_pubs[self._duty_topic]
            pub.publish(Float64MultiArray(data=[0.0, 0.0]))
            pub.wait_for_all_acked(Duration(seconds=1.0))
            self.get_logger().info(f"sent duty [0, 0] on '{self._topic_out[self._duty_topic]}'")

    def stop(self) -> None:
        """Stop playback (if running) and make sure the duty is zeroed; idempotent."""
        self._stop_event.set()
        if self._worker is not None:
            self._worker.join(timeout=5.0)
        self._send_zero_duty()

    def _publish_diagnostics(self) -> None:
        stats = self._player.stats
        late = np.asarray(stats.lateness_ns[-1000:], dtype=float) * 1e-6
        state = 'finished' if self.finished.is_set() else 'playing'
        level, text = (ERROR, f'failed: {self._error}') if self._error else (OK, state)
        self._diag.publish(level, text, [
            ('bag', self._reader.path), ('published', stats.published), ('loops', stats.loops),
            ('lateness_p99_ms', f'{np.percentile(late, 99):.3f}' if late.size else 'n/a')])

    def destroy_node(self) -> None:
        """Stop playback (zeroing the duty), then destroy the node."""
        self.stop()
        super().destroy_node()


def main(args: Optional[Sequence[str]] = None) -> int:
    """Console entry point: play the bag; SIGINT/SIGTERM stop it and zero the duty first."""
    # The stop flag leaves the context up, so the duty can still be zeroed on the way out.
    handle_command_line('replay', __doc__, PARAMETERS, args)
    stop = init_with_stop_signals(args, 'replay')
    node, code = None, 0
    try:
        node = create_node('replay', ReplayNode, args)
        node.start()
        spin_until_stopped(node, stop, done=node.finished.is_set)
        code = 1 if node._error else 0
    except (BagError, ValueError) as err:
        print(f'replay: {err}', file=sys.stderr)
        code = 1
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    sys.exit(main())
