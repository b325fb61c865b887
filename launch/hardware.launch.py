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
Launch the hardware loop: hardware_bridge, controller; setpoint and recorder optional.

    ros2 launch sma_actuator hardware.launch.py port:=/dev/ttyACM0 mode:=pi_inverse

The bridge talks to the MCU on `port` (docs/protocol.md); the loop runs on the wall clock.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction

from sma_actuator import launching as sl


def _nodes(context):
    bridge = sl.node(context, 'hardware_bridge', {'port': sl.arg(context, 'port')})
    source = [sl.setpoint(context)] if sl.flag(context, 'setpoint') else []
    return [bridge, sl.controller(context), *source, *sl.recorder(context)]


def generate_launch_description():
    """Return the hardware loop's launch description."""
    return LaunchDescription([
        *sl.common_arguments(use_sim_time='false'),
        DeclareLaunchArgument('port', default_value='', description=(
            'Serial device or pyserial URL of the MCU; empty: config/hardware_bridge.yaml.')),
        DeclareLaunchArgument('setpoint', default_value='false', choices=['true', 'false'],
                              description='Also run the setpoint node (profile argument).'),
        OpaqueFunction(function=_nodes),
    ])
