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
Turn a recorded run (MCAP bag) into aligned numpy arrays for the model workbench.

All signals are put on one uniform time grid built on the recorder's log time (receive time,
the one clock every topic shares), starting at the first ``<ns>/joint_states`` message (``<ns>``
is the actuator's namespace, ``/sma`` by default, found in the bag):

- ``position`` [rad]: linear interpolation between joint-state samples (a measured,
  continuous signal);
- ``duty_a``, ``duty_b`` [0..1]: zero-order hold of ``<ns>/applied_duty`` when the bag holds
  it (the duty the hardware bridge sent to the MCU, after its interlock, clamp and watchdog),
  else of the commands on ``<ns>/duty`` (a command holds until the next one); 0 before the
  first message, since the amplifiers start switched off;
- ``setpoint`` [rad]: zero-order hold, NaN before the first setpoint;
- ``ambient_temperature`` [degC]: zero-order hold, the first reading held backwards to the
  start (ambient changes slowly, and a NaN would stop the model).
- ``position_measured`` (with ``bridged_steps``): False strictly inside a joint-state gap
  longer than that many median steps, where ``position`` is a straight line, not a measurement.

Messages are decoded from the definition stored in the bag (mcap-ros2-support), so this works
without ROS installed and on bags recorded by rosbag2.
"""
from pathlib import Path
from typing import Dict, List, Optional, Union

from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
import numpy as np

from .applied import altered_duty_notes
from .errors import BagError, MissingTopicError, TruncatedBagError, UnknownTypeError
from .reader import BagReader

#: role -> (topic name relative to the actuator's namespace, expected type)
ROLES = {
    'joint_states': ('joint_states', 'sensor_msgs/msg/JointState'),
    'duty': ('duty', 'std_msgs/msg/Float64MultiArray'),
    'applied_duty': ('applied_duty', 'std_msgs/msg/Float64MultiArray'),
    'setpoint': ('setpoint', 'std_msgs/msg/Float64'),
    'ambient_temperature': ('ambient_temperature', 'sensor_msgs/msg/Temperature'),
}
#: Namespace assumed when the bag holds no joint states at all (the nodes' default).
DEFAULT_NAMESPACE = '/sma'
REQUIRED_ROLES = ('joint_states', 'duty')
JOINT_NAME = 'shaft'
#: Largest grid load_run builds (10 h at 1 kHz); beyond that the log times are suspect.
MAX_SAMPLES = 36_000_000
#: Grid points allowed per joint-state message (resampling up to 100x the recorded rate).
MAX_GRID_PER_MESSAGE = 100
_NS = 1e-9


def _joint_position(msg, path: Path) -> float:
    names = list(msg.name)
    if JOINT_NAME in names:
        index = names.index(JOINT_NAME)
    elif len(msg.position) == 1:
        index = 0  # a single unnamed/renamed joint is the shaft
    else:
        raise BagError(path, f"joint state without a '{JOINT_NAME}' joint (joints: {names})")
    return float(msg.position[index])


def _duty_pair(msg, path: Path):
    if len(msg.data) != 2:
        raise BagError(path, f'duty message with {len(msg.data)} values (expected '
                             '[duty_a, duty_b])')
    return float(msg.data[0]), float(msg.data[1])


_EXTRACT = {
    'joint_states': _joint_position,
    'duty': _duty_pair,
    'applied_duty': _duty_pair,
    'setpoint': lambda msg, path: float(msg.data),
    'ambient_temperature': lambda msg, path: float(msg.temperature),
}


def bag_namespace(reader: BagReader, path: Path) -> str:
    """
    Return the namespace of the one actuator recorded in a bag (``/sma``, ``/left``, ``/``).

    It is the namespace of the bag's ``.../duty`` topic (the command, which only the actuator's
    own loop publishes), else of its ``.../joint_states`` topic (a replayed measurement may sit
    beside the actuator's, e.g. ``/measured/joint_states``); DEFAULT_NAMESPACE if neither.

    :raises BagError: The bag holds several actuators: pass ``namespace``.
    """
    for role in ('duty', 'joint_states'):
        name, type_name = ROLES[role]
        found = sorted(topic.rsplit('/', 1)[0] or '/' for topic, info in reader.topics.items()
                       if topic.rsplit('/', 1)[-1] == name and info.type == type_name
                       and info.message_count)
        if len(found) > 1:
            raise BagError(path, f'{name} of several actuators {found}: pass namespace= to '
                                 'choose one')
        if found:
            return found[0]
    return DEFAULT_NAMESPACE


def _topic_map(topics: Optional[Dict[str, str]], namespace: str) -> Dict[str, str]:
    prefix = namespace.rstrip('/') + '/'
    mapping = {role: prefix + name for role, (name, _) in ROLES.items()}
    unknown = set(topics or {}) - set(ROLES)
    if unknown:
        raise ValueError(f'unknown topic roles {sorted(unknown)}; valid roles: {sorted(ROLES)}')
    mapping.update(topics or {})
    return mapping


def _read_series(reader: BagReader, path: Path, topic_of: Dict[str, str]):
    """Decode each present role's topic to (log times [ns], values)."""
    series, decoders, role_of = {}, {}, {}
    factory = DecoderFactory()
    for schema_id, (role, topic) in enumerate(topic_of.items(), start=1):
        info = reader.topics.get(topic)
        if info is None or info.message_count == 0:
            if role in REQUIRED_ROLES:
                raise MissingTopicError(
                    path, f"required topic '{topic}' ({ROLES[role][1]}) has no messages in the "
                          f'bag; topics present: {sorted(reader.topics)}')
            continue
        expected = ROLES[role][1]
        if info.type != expected:
            raise UnknownTypeError(path, f"topic '{topic}' has type '{info.type}', "
                                         f"expected '{expected}'")
        if info.schema_encoding != 'ros2msg' or info.serialization_format != 'cdr':
            raise UnknownTypeError(
                path, f"topic '{topic}' is stored as {info.schema_encoding or 'no schema'}/"
                      f'{info.serialization_format}; only ros2msg/cdr can be decoded')
        # DecoderFactory caches decoders by schema id, so each needs its own id.
        schema = Schema(id=schema_id, name=info.type, encoding='ros2msg',
                        data=info.definition.encode())
        try:
            decoders[topic] = factory.decoder_for('cdr', schema)
        except Exception as err:  # noqa: BLE001 - any parse failure of the stored text
            raise UnknownTypeError(path, f"cannot read the definition of '{info.type}' stored "
                                         f"for '{topic}': {type(err).__name__}: "
                                         f'{str(err)[:200]}') from None
        role_of[topic] = role
        series[role] = ([], [])
    for msg in reader.messages(topics=list(role_of)):
        role = role_of[msg.topic]
        try:
            value = _EXTRACT[role](decoders[msg.topic](msg.data), path)
        except BagError:
            raise
        except Exception as err:  # noqa: BLE001 - name the file and message, keep the cause
            raise BagError(path, f"cannot decode a '{msg.topic}' message logged at "
                                 f'{msg.log_time_ns} ns: {type(err).__name__}: '
                                 f'{str(err)[:200]}') from None
        series[role][0].append(msg.log_time_ns)
        series[role][1].append(value)
    return {role: (np.asarray(t, dtype=np.int64), np.asarray(v, dtype=float))
            for role, (t, v) in series.items()}


def _sorted(times, values):
    order = np.argsort(times, kind='stable')
    return times[order], values[order]


def zero_order_hold(times_ns, values, grid_ns, before=np.nan):
    """
    Sample a piecewise-constant signal on a grid.

    :param times_ns: Sample times [ns], ascending.
    :param values: Values at those times (1-D or 2-D with samples along axis 0).
    :param grid_ns: Query times [ns].
    :param before: Value for grid points before the first sample.
    :return: The last value at or before each grid time.
    """
    index = np.searchsorted(times_ns, grid_ns, side='right') - 1
    out = np.asarray(values, dtype=float)[np.clip(index, 0, None)]
    out[index < 0] = before
    return out


def default_rate_hz(times_ns) -> float:
    """Return the sample rate [Hz] of a series as 1 / median sample interval."""
    steps = np.diff(times_ns)
    steps = steps[steps > 0]
    if steps.size == 0:
        raise ValueError('cannot infer a rate from fewer than two distinct sample times')
    return 1.0 / (float(np.median(steps)) * _NS)


def long_gaps(times_ns: np.ndarray, bridged_steps: float) -> tuple:
    """
    Return (k, median step [ns]): the steps t[k] -> t[k + 1] over `bridged_steps` medians.

    `times_ns` ascending, two distinct at least; a step longer than `bridged_steps` median
    steps is a gap (messages lost, a sensor that stopped publishing), not a sample interval.
    """
    steps = np.diff(times_ns)
    median = float(np.median(steps[steps > 0]))
    return np.flatnonzero(steps > bridged_steps * median), median


def unmeasured(times_ns: np.ndarray, grid_ns: np.ndarray, bridged_steps: float) -> np.ndarray:
    """
    Return the grid times [ns] that lie strictly inside a gap of `long_gaps` (True there).

    The position interpolated there is not a measurement (a straight line across the gap).
    """
    k = np.searchsorted(times_ns, grid_ns, side='right') - 1   # last sample at or before
    in_gap = np.zeros(times_ns.size, bool)
    in_gap[long_gaps(times_ns, bridged_steps)[0]] = True
    k = np.clip(k, 0, times_ns.size - 1)
    return in_gap[k] & (grid_ns > times_ns[k])


def gap_note(times_ns: np.ndarray, bridged_steps: float) -> Optional[str]:
    """
    Say where joint-state times [ns] leave gaps over `bridged_steps` median steps, or None.

    On the grid of :func:`load_run` the position is interpolated across such a gap (messages
    lost, a sensor that stopped publishing): that part of the record is not measured.
    """
    long, median = long_gaps(times_ns, bridged_steps)
    if long.size == 0:
        return None
    lengths = np.diff(times_ns)[long] * _NS
    where = (times_ns[long[np.argmax(lengths)]] - times_ns[0]) * _NS
    rule = f'over {bridged_steps:g} median steps of {median * _NS:.4g} s'
    what = (f'a gap of {lengths[0]:.3f} s in the joint states ({rule})' if long.size == 1 else
            f'{long.size} gaps in the joint states ({rule}; {lengths.sum():.3f} s in all), '
            f'the longest {lengths.max():.3f} s')
    return (f'{what} from {where:.3f} s after the first: the position there is interpolated, '
            'not measured')


def load_run(path: Union[str, Path], rate_hz: Optional[float] = None,
             topics: Optional[Dict[str, str]] = None,
             namespace: Optional[str] = None, notes: Optional[List[str]] = None,
             bridged_steps: Optional[float] = None) -> Dict[str, np.ndarray]:
    """
    Load a recorded run as arrays on a uniform time grid (see module doc for the rules).

    :param path: Bag directory or ``.mcap`` file (ours or rosbag2's).
    :param rate_hz: Grid rate [Hz]; default: the joint-state rate (1 / median interval).
    :param topics: Override topic names by role: ``joint_states``, ``duty``,
        ``applied_duty``, ``setpoint``, ``ambient_temperature`` (e.g. ``{'joint_states':
        '/measured/joint_states'}``; ``{'applied_duty': ''}`` loads the commands).
    :param namespace: The actuator's namespace (``/left``); default: found in the bag
        (:func:`bag_namespace`).
    :param notes: A list that receives one line per recovered file (what a cut-off or
        damaged file kept and lost, :class:`RecoveryReport`) and, with ``bridged_steps``, one
        line on the joint-state gaps longer than that many median steps, whose position is
        interpolated, not measured (:func:`gap_note`); one line when the duty is read from
        the applied-duty topic; and one line per node whose /diagnostics count duty commands
        it held or clamped (:func:`applied.altered_duty_notes`).
    :param bridged_steps: Joint-state steps longer than this many median steps are gaps
        (:func:`long_gaps`); default: none are.
    :return: ``time`` [s from the first joint state], ``duty_a``, ``duty_b`` [0..1],
        ``position`` [rad], and when recorded ``ambient_temperature`` [degC], ``setpoint`` [rad];
        with ``bridged_steps``, ``position_measured`` (bool: False inside those gaps).
    :raises BagError: (a ValueError) naming the file: missing, not MCAP, empty/truncated with
        nothing recoverable, wrong or unknown types, missing required topics, undecodable data.
    """
    path = Path(path)
    reader = BagReader(path)
    if reader.message_count == 0 and reader.recoveries:
        raise TruncatedBagError(path, 'no complete chunk in the file; nothing was recovered')
    if namespace is None:
        namespace = bag_namespace(reader, path)
    elif not namespace.startswith('/'):
        raise ValueError(f'namespace must be absolute (start with /), got {namespace!r}')
    topic_of = _topic_map(topics, namespace)
    data = _read_series(reader, path, topic_of)
    js_t, js_pos = _sorted(*data['joint_states'])
    if np.unique(js_t).size < 2:
        raise MissingTopicError(path, 'needs at least two joint states at distinct times')
    if notes is not None:
        notes.extend(str(report) for report in reader.recoveries)
        applied = topic_of['applied_duty'] if 'applied_duty' in data else None
        if applied:
            notes.append(f'{path}: duty read from {applied}, as the hardware applied it, not '
                         f"from the commands on {topic_of['duty']}")
        notes.extend(altered_duty_notes(reader, path, topic_of['duty'], applied))
        gaps = None if bridged_steps is None else gap_note(js_t, bridged_steps)
        if gaps:
            notes.append(f'{path}: {gaps}')
    rate = default_rate_hz(js_t) if rate_hz is None else float(rate_hz)
    if not np.isfinite(rate) or rate <= 0:
        raise ValueError(f'rate_hz must be a positive number, got {rate_hz!r}')
    span_s = (js_t[-1] - js_t[0]) * _NS
    samples = np.floor(span_s * rate + 1e-9) + 1  # float: a huge rate must not overflow int
    # The grid may hold at most MAX_GRID_PER_MESSAGE points per joint state: more means the
    # log times jump (damaged data, or sim time before /clock), not a real recording.
    limit = min(MAX_SAMPLES, MAX_GRID_PER_MESSAGE * js_t.size + 1000)
    if not samples <= limit:
        raise BagError(path, f'joint states span {span_s:.6g} s: at {rate:g} Hz that is '
                             f'{samples:.6g} samples (limit {limit} for {js_t.size} joint '
                             'states); log times jump, e.g. recorded on sim time before '
                             '/clock started or damaged data, or the rate is too high')
    count = int(samples)
    grid = js_t[0] + np.round(np.arange(count) / rate * 1e9).astype(np.int64)
    duty_t, duty = _sorted(*data.get('applied_duty', data['duty']))
    duty_ab = zero_order_hold(duty_t, duty, grid, before=0.0)
    out = {'time': (grid - js_t[0]) * _NS,
           'duty_a': duty_ab[:, 0], 'duty_b': duty_ab[:, 1],
           'position': np.interp(grid, js_t, js_pos)}
    if bridged_steps is not None:
        out['position_measured'] = ~unmeasured(js_t, grid, bridged_steps)
    if 'ambient_temperature' in data:
        amb_t, amb = _sorted(*data['ambient_temperature'])
        out['ambient_temperature'] = zero_order_hold(amb_t, amb, grid, before=amb[0])
    if 'setpoint' in data:
        out['setpoint'] = zero_order_hold(*_sorted(*data['setpoint']), grid)
    return out
