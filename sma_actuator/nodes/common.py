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
Helpers shared by the nodes.

Topic names, QoS, parameter descriptors, diagnostics, config, and the signal-safe spin loop every
console script runs.
"""
from pathlib import Path
import signal
import threading

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType)
import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

# Topic names, relative to the node's namespace, so `-r __ns:=/left` (or launch_ros
# `Node(namespace=...)`) moves a whole actuator. Every node defaults to NAMESPACE, so the
# default names stay /sma/setpoint, /sma/duty, ... /diagnostics and /clock stay absolute
# (one per ROS graph, by ROS convention).
NAMESPACE = 'sma'
SETPOINT = 'setpoint'
DUTY = 'duty'
JOINT_STATES = 'joint_states'
AMBIENT_TEMPERATURE = 'ambient_temperature'
DIAGNOSTICS = '/diagnostics'
CLOCK = '/clock'
JOINT_NAME = 'shaft'
WIRE_FRAMES = ('wire_a', 'wire_b')
# one sensor_msgs/Temperature topic per wire (plotting tools key series by topic)
WIRE_TEMPERATURES = tuple(f'{frame}/temperature' for frame in WIRE_FRAMES)

# feedback streams: newest sample wins, a lost one is not worth a retransmission
SENSOR_QOS = qos_profile_sensor_data
# commands: every setpoint and duty must arrive (a lost "zero duty" would leave heat on)
COMMAND_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
DIAGNOSTICS_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
CLOCK_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR


def node_options(kwargs):
    """
    Return rclpy Node keyword arguments with the namespace defaulting to NAMESPACE.

    A `__ns` remap on the command line (`--ros-args -r __ns:=/left`, which launch_ros
    `Node(namespace=...)` passes) still takes precedence over this default, as in rcl.
    """
    return {'namespace': NAMESPACE, **kwargs}


def expiring_command_qos(lifespan_s):
    """
    Return COMMAND_QOS with a lifespan: samples older than `lifespan_s` are never taken.

    For the duty subscriptions of the plant and the bridge (docs/safety.md): a sample
    queued while the process was frozen expires instead of replaying old heat.
    """
    return QoSProfile(depth=COMMAND_QOS.depth, reliability=COMMAND_QOS.reliability,
                      lifespan=Duration(seconds=lifespan_s))


def install_stop_signals():
    """
    SIGINT and SIGTERM set the returned Event and raise nothing.

    Why not rclpy's handler: it chains to Python's default SIGINT handler, and the
    KeyboardInterrupt it raises can land inside a pybind11 call of the executor
    (`take_message`), which turns it into "RuntimeError: Unable to convert call argument"
    and exit status 1 (ros/joint_state_publisher#117; seen here under load). A flag that the
    spin loop polls stops every node between callbacks, with its context still valid, so
    the shutdown path can still publish a zero duty.
    """
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    return stop


def init_with_stop_signals(args=None):
    """`rclpy.init(args)` without rclpy's signal handlers; returns `install_stop_signals()`."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    return install_stop_signals()


def spin_until_stopped(node, stop, done=None, poll_s=0.05):
    """
    Spin `node` until `stop` is set, `done()` is true or its context is shut down.

    A signal is seen within poll_s (the wait returns at least that often). Returns the
    executor, so a caller can still drain queued messages after the stop.
    """
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        while not stop.is_set() and node.context.ok() and not (done and done()):
            executor.spin_once(timeout_sec=poll_s)
    except ExternalShutdownException:
        pass   # someone else shut the context down: a normal stop
    return executor


def declare_float(node, name, default, description, lo=None, hi=None, read_only=False):
    """Declare a double parameter with a described range [lo, hi]; return its value."""
    d = ParameterDescriptor(description=description, type=ParameterType.PARAMETER_DOUBLE,
                            read_only=read_only)
    if lo is not None:
        d.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi))]
    return node.declare_parameter(name, float(default), d).value


def declare_int(node, name, default, description, lo, hi, read_only=False):
    """Declare an integer parameter with a range [lo, hi]; return its value."""
    d = ParameterDescriptor(description=description, type=ParameterType.PARAMETER_INTEGER,
                            read_only=read_only,
                            integer_range=[IntegerRange(from_value=int(lo), to_value=int(hi))])
    return node.declare_parameter(name, int(default), d).value


def declare_bool(node, name, default, description, read_only=False):
    """Declare a bool parameter; return its value."""
    d = ParameterDescriptor(description=description, type=ParameterType.PARAMETER_BOOL,
                            read_only=read_only)
    return node.declare_parameter(name, bool(default), d).value


def declare_str(node, name, default, description, choices=None, read_only=False):
    """Declare a string parameter (choices listed in the description); return its value."""
    if choices:
        description = f'{description} One of: {", ".join(choices)}.'
    d = ParameterDescriptor(description=description, type=ParameterType.PARAMETER_STRING,
                            read_only=read_only, additional_constraints=(
                                f'one of {list(choices)}' if choices else ''))
    value = node.declare_parameter(name, str(default), d).value
    if choices and value not in choices:
        raise ValueError(f'parameter {name}={value!r} must be one of {list(choices)}')
    return value


def stamp_to_s(stamp):
    """builtin_interfaces/Time -> seconds (float)."""
    return stamp.sec + 1e-9 * stamp.nanosec


def config_path(name):
    """Path of a file in the package's config/: the installed share dir, else the source tree."""
    try:
        from ament_index_python.packages import get_package_share_directory
        p = Path(get_package_share_directory('sma_actuator')) / 'config' / name
        if p.exists():
            return p
    except Exception:   # not on an ament index (plain venv): fall back to the source tree
        pass
    return Path(__file__).resolve().parents[2] / 'config' / name


class Diagnostics:
    """Publishes one DiagnosticStatus (`<node>: <name>`) on /diagnostics."""

    def __init__(self, node, name, hardware_id=None):
        self.node = node
        self.name = f'{node.get_name()}: {name}'
        # the node's full name tells two actuators (namespaces) apart on the one /diagnostics
        self.hardware_id = hardware_id or node.get_fully_qualified_name()
        self.pub = node.create_publisher(DiagnosticArray, DIAGNOSTICS, DIAGNOSTICS_QOS)

    def publish(self, level, message, values=None, stamp=None):
        """Send level (OK/WARN/ERROR), message and key values (str() of each value)."""
        msg = DiagnosticArray()
        msg.header.stamp = stamp or self.node.get_clock().now().to_msg()
        status = DiagnosticStatus(level=level, name=self.name, message=message,
                                  hardware_id=self.hardware_id)
        status.values = [KeyValue(key=k, value=_fmt(v)) for k, v in (values or {}).items()]
        msg.status = [status]
        self.pub.publish(msg)


def _fmt(v):
    return f'{v:.6g}' if isinstance(v, float) else str(v)
