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
The ROS graph interface the nodes share: topic names, QoS profiles and small helpers.

Parameters are declared through :mod:`.ros_params`, diagnostics published through
:mod:`.ros_diagnostics`, and every console script runs through :mod:`.ros_console`.
"""
from pathlib import Path
from typing import Any, Dict

from builtin_interfaces.msg import Time
from rclpy.duration import Duration
from rclpy.qos import qos_profile_sensor_data, QoSProfile, ReliabilityPolicy

# Topic names, relative to the node's namespace, so `-r __ns:=/left` (or launch_ros
# `Node(namespace=...)`) moves a whole actuator. Every node defaults to NAMESPACE, so the
# default names stay /sma/setpoint, /sma/duty, ... /diagnostics and /clock stay absolute
# (one per ROS graph, by ROS convention).
NAMESPACE = 'sma'
SETPOINT = 'setpoint'
DUTY = 'duty'
# the duty the hardware applied (after its interlock and limits), as the bridge sent it
APPLIED_DUTY = 'applied_duty'
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


def node_options(kwargs: Dict[str, Any]) -> Dict[str, Any]:
    """
    Return rclpy Node keyword arguments with the namespace defaulting to NAMESPACE.

    A `__ns` remap on the command line (`--ros-args -r __ns:=/left`, which launch_ros
    `Node(namespace=...)` passes) still takes precedence over this default, as in rcl.
    """
    return {'namespace': NAMESPACE, **kwargs}


def expiring_command_qos(lifespan_s: float) -> QoSProfile:
    """
    Return COMMAND_QOS with a lifespan: samples older than `lifespan_s` are never taken.

    For the duty subscriptions of the plant and the bridge (docs/safety.md): a sample
    queued while the process was frozen expires instead of replaying old heat.
    """
    return QoSProfile(depth=COMMAND_QOS.depth, reliability=COMMAND_QOS.reliability,
                      lifespan=Duration(seconds=lifespan_s))


def stamp_to_s(stamp: Time) -> float:
    """builtin_interfaces/Time -> seconds (float)."""
    return stamp.sec + 1e-9 * stamp.nanosec


def config_path(name: str) -> Path:
    """Path of a file in the package's config/: the installed share dir, else the source tree."""
    try:
        from ament_index_python.packages import get_package_share_directory
        p = Path(get_package_share_directory('sma_actuator')) / 'config' / name
        if p.exists():
            return p
    except Exception:   # not on an ament index (plain venv): fall back to the source tree
        pass
    return Path(__file__).resolve().parents[2] / 'config' / name
