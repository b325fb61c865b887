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
recorder node: record topics to a rosbag2-compatible MCAP bag (docs/recording.md).

Subscribes (raw, so the CDR bytes are stored as received) to every topic matching ``topics``
as soon as it has a publisher, with the QoS rosbag2 would request (reliable/transient_local
only if all publishers offer it), and writes through :class:`sma_actuator.bag.BagWriter`.
Log time is the node clock at reception, publish time the publisher's source timestamp.
SIGINT/SIGTERM close the bag properly; after SIGKILL the file is readable up to the last chunk.
A write failure (full disk, file size limit, unwritable directory) reports ERROR on
/diagnostics, closes what it can (the flushed chunks stay readable) and ends the console
script with exit status 1 and one line on stderr.

Run: ``recorder --ros-args --params-file config/recorder.yaml -p run_name:=step1``
Embed: ``RecorderNode(context=ctx, bag_path='runs/step1/bag')`` on any executor, then
``close()`` (or ``destroy_node()``) when the run ends.
"""
import functools
import sys
from typing import Any, Dict, List, Optional, Sequence

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.context import Context
from rclpy.node import Node
from sma_actuator.bag.errors import BagError, BagWriteError
from sma_actuator.bag.metadata import BagRecord
from sma_actuator.bag.msgdefs import type_description_hash
from sma_actuator.bag.qos import adapt_request_to_offers
from sma_actuator.bag.recording import (
    bag_directory,
    DEFAULT_NAME_TEMPLATE,
    DEFAULT_TOPICS,
    TopicSelector,
)
from sma_actuator.bag.writer import BagWriter, COMPRESSIONS
from sma_actuator.nodes.common import NAMESPACE
from sma_actuator.nodes.ros_bag import message_class, publisher_offers, qos_profile, take_pending
from sma_actuator.nodes.ros_console import (
    create_node,
    handle_command_line,
    init_with_stop_signals,
    spin_until_stopped,
)
from sma_actuator.nodes.ros_diagnostics import Diagnostics, ERROR, OK, WARN
from sma_actuator.nodes.ros_params import declare_parameters, overrides_from_kwargs, Param

PARAMETERS = (
    Param('topics', list(DEFAULT_TOPICS), 'Topic names or glob patterns to record (* also '
          'matches /; relative ones are in the node namespace)'),
    Param('bag_path', '', 'Bag directory to write; empty: output_dir/<name from '
          'name_template>'),
    Param('output_dir', 'runs', 'Directory in which the bag directory is created'),
    Param('run_name', 'run', 'Run name used in name_template'),
    Param('name_template', DEFAULT_NAME_TEMPLATE, 'Bag directory name; fields {run_name}, '
          '{date:<strftime>}'),
    Param('overwrite', False, 'Replace an existing bag at the same path (else refuse to '
          'start)'),
    Param('compression', 'zstd', 'Chunk compression', choices=tuple(sorted(COMPRESSIONS))),
    Param('chunk_size_bytes', 256 * 1024, 'Close a chunk at this size [bytes]', (1024, 1 << 30)),
    Param('chunk_max_age_s', 1.0, 'Close a chunk at this age [s]: bounds data lost on SIGKILL',
          (0.0, 60.0)),
    Param('max_file_size_bytes', 0, 'Start a new .mcap file past this size [bytes]; 0: never',
          (0, 1 << 50)),
    Param('max_file_duration_s', 0.0, 'Start a new .mcap file past this span [s]; 0: never',
          (0.0, 1e6)),
    Param('queue_depth', 1000, 'Subscription queue depth [messages]', (1, 100000)),
    Param('discovery_period_s', 0.5, 'Look for new matching topics every this many seconds '
          '[s]', (0.01, 60.0)),
    Param('diagnostics_period_s', 1.0, 'Publish /diagnostics every this many seconds [s]',
          (0.1, 60.0)),
)
# executor cycles after SIGINT/SIGTERM to take messages that already arrived
DRAIN_CYCLES = 10


class RecorderNode(Node):
    """
    Record matching topics into a bag; see module doc.

    :param context: rclpy context (tests, embedding); default: the global one.
    :param namespace: Node namespace; relative ``topics`` patterns resolve in it (a
        ``__ns`` remap on the command line overrides it).
    :param params: Parameter values by name (same names as config/recorder.yaml).
    :raises BagError: The bag cannot be created (exists and not overwrite, bad name...).
    :raises ValueError: An unknown parameter name or a bad value.
    """

    def __init__(self, *, context: Optional[Context] = None, node_name: str = 'recorder',
                 namespace: str = NAMESPACE, **params: Any) -> None:
        super().__init__(node_name, context=context, namespace=namespace,
                         parameter_overrides=overrides_from_kwargs(PARAMETERS, params))
        p = declare_parameters(self, PARAMETERS)
        self._selector = TopicSelector(p['topics'], self.get_namespace())
        path = p['bag_path'] or bag_directory(p['output_dir'], p['run_name'],
                                              p['name_template'])
        self._diag = Diagnostics(self, 'recording')
        try:
            self.bag = BagWriter(path, compression=p['compression'],
                                 chunk_size_bytes=p['chunk_size_bytes'],
                                 chunk_max_age_s=p['chunk_max_age_s'],
                                 max_file_size_bytes=p['max_file_size_bytes'],
                                 max_file_duration_s=p['max_file_duration_s'],
                                 overwrite=p['overwrite'])
        except BagWriteError as err:
            self._diag.publish(ERROR, str(err), [('bag', path)])
            raise
        self._depth = p['queue_depth']
        self._recording_subs = {}
        self._skipped = {}  # topic -> reason, reported once
        self._write_errors = 0
        self._closed = False
        self.failure = None   # the BagWriteError that stopped the recording, if any
        # discovery, flushing and diagnostics run on the steady clock: with use_sim_time a
        # sim clock that has not started yet (a plant waiting for its subscribers) must not
        # keep the recorder from subscribing
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(p['discovery_period_s'], self._discover, clock=steady)
        if p['chunk_max_age_s'] > 0:
            self.create_timer(p['chunk_max_age_s'] / 2, self._flush_if_due, clock=steady)
        self.create_timer(p['diagnostics_period_s'], self._publish_diagnostics, clock=steady)
        self.get_logger().info(f'recording {self._selector.patterns} to {self.bag.path}')
        self._discover()

    @property
    def recorded_topics(self) -> List[str]:
        """Topics subscribed so far."""
        return sorted(self._recording_subs)

    def _discover(self) -> None:
        if self._closed:
            return
        for topic, types in self.get_topic_names_and_types():
            if topic in self._recording_subs or not self._selector.matches(topic):
                continue
            if len(types) != 1:
                self._skip(topic, f'has several types {types}; one bag topic holds one type')
                continue
            offers, type_hash = publisher_offers(self, topic)
            if not offers:
                continue  # only subscribers so far: QoS unknown, wait for a publisher
            try:
                self._subscribe(topic, types[0], offers, type_hash)
            except BagError as err:
                self._skip(topic, str(err))

    def _subscribe(self, topic: str, type_name: str, offers: List[Dict[str, Any]],
                   type_hash: str) -> None:
        msg_type = message_class(type_name)
        installed = type_description_hash(type_name)
        if type_hash and type_hash != installed:
            self.get_logger().warning(f"'{topic}': publishers use type hash {type_hash}, the "
                                      f'installed {type_name} has {installed}; recording anyway')
        self.bag.add_topic(topic, type_name, offers, type_hash=type_hash or installed)
        request = adapt_request_to_offers(offers)
        self._recording_subs[topic] = self.create_subscription(
            msg_type, topic, functools.partial(self._on_message, topic),
            qos_profile(request['reliability'], request['durability'], self._depth), raw=True)
        self.get_logger().info(f"recording '{topic}' ({type_name}, {request['reliability']})")

    def _skip(self, topic: str, reason: str) -> None:
        if self._skipped.get(topic) != reason:
            self._skipped[topic] = reason
            self.get_logger().error(f"not recording '{topic}': {reason}")

    def _on_message(self, topic: str, data: bytes, info: Dict[str, int]) -> None:
        self._write(topic, data, info)
        if self._closed:
            return   # a write failure closed the bag and destroyed the subscriptions
        # take the rest of the queue now, not one message per executor cycle (see take_pending)
        for data, info in take_pending(self._recording_subs[topic]):
            self._write(topic, data, info)
            if self._closed:
                break

    def _write(self, topic: str, data: bytes, info: Dict[str, int]) -> None:
        if self._closed:
            return
        log_time = self.get_clock().now().nanoseconds
        try:
            self.bag.write(topic, data, log_time, info.get('source_timestamp') or log_time)
        except (OSError, BagError) as err:
            self._write_errors += 1
            if self.bag.failed is not None:
                self._fail(self.bag.failed)
                return
            self.get_logger().error(f"cannot write '{topic}' message: {err}",
                                    throttle_duration_sec=5.0)

    def _flush_if_due(self) -> None:
        if self._closed:
            return
        try:
            self.bag.flush_if_due()
        except BagError as err:
            self._fail(err)

    def _fail(self, err: BagError) -> None:
        """Stop recording after a write failure: ERROR on /diagnostics, close what we can."""
        if self.failure is not None:
            return
        self.failure = err
        self.get_logger().error(f'recording stopped: {err}')
        self._publish_diagnostics()
        self.close()

    def _publish_diagnostics(self) -> None:
        if self._closed:
            return
        if self.failure is not None:
            level, text = ERROR, f'recording stopped: {self.failure}'
        elif self._write_errors:
            level, text = ERROR, f'{self._write_errors} messages could not be written'
        elif not self._recording_subs:
            level, text = WARN, 'no matching topic with a publisher yet'
        else:
            level, text = OK, f'recording {len(self._recording_subs)} topics'
        values = [('bag', self.bag.path), ('messages', self.bag.message_count),
                  ('bytes_on_disk', self.bag.bytes_on_disk), ('write_errors', self._write_errors)]
        values += [(f'count {t}', r.message_count) for t, r in self.bag.topics.items()]
        values += [(f'skipped {t}', reason) for t, reason in self._skipped.items()]
        self._diag.publish(level, text, values)

    def close(self) -> BagRecord:
        """
        Stop recording and finish the bag (summary, metadata.yaml); idempotent.

        :return: The bag's metadata record (files, topics, counts).
        """
        if not self._closed:
            self._closed = True
            # The file first: after a signal the context may be down and destroying fail.
            record = self.bag.close()
            for sub in self._recording_subs.values():
                try:
                    self.destroy_subscription(sub)
                except Exception:  # noqa: BLE001 - handle already invalid after shutdown
                    pass
            self.get_logger().info(f'closed {self.bag.path}: {self.bag.message_count} messages '
                                   f'on {len(record.topics)} topics'
                                   + (' (after a write failure)' if self.failure else ''))
        return self.bag.close()

    def destroy_node(self) -> None:
        """Close the bag, then destroy the node."""
        self.close()
        super().destroy_node()


def main(args: Optional[Sequence[str]] = None) -> int:
    """Console entry point: record until SIGINT/SIGTERM, take what is queued, close the bag."""
    # The stop flag leaves the context up, so messages that already arrived but were not
    # taken yet are still drained into the bag.
    handle_command_line('recorder', __doc__, PARAMETERS, args)
    stop = init_with_stop_signals(args, 'recorder')
    node, code = None, 0
    try:
        node = create_node('recorder', RecorderNode, args)
        executor = spin_until_stopped(node, stop, poll_s=0.1,
                                      done=lambda: node.failure is not None)
        if node.failure is not None:
            raise node.failure
        for _ in range(DRAIN_CYCLES):
            executor.spin_once(timeout_sec=0.02)
    except (BagError, ValueError) as err:
        print(f'recorder: {err}', file=sys.stderr)
        code = 1
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    sys.exit(main())
