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
Launch the MCU emulator (a plain process) and the hardware loop on its pseudo-terminal.

    ros2 launch sma_actuator emulator.launch.py profile:=step

mcu_emulator serves the serial protocol on a pty linked at `link`; hardware.launch.py runs
with port:=<link> (the bridge retries until the emulator has created it).
"""
import os

from ament_index_python.packages import get_package_prefix
from launch import LaunchDescription
from launch.actions import (DeclareLaunchArgument, ExecuteProcess,
                            IncludeLaunchDescription, OpaqueFunction)
from launch.launch_description_sources import PythonLaunchDescriptionSource

from sma_actuator import launching as sl

FORWARDED = ('namespace', 'mode', 'profile', 'params_file', 'use_sim_time', 'record',
             'bag_path', 'log_level', 'setpoint')


def _emulator_and_loop(context):
    link = sl.arg(context, 'link')
    executable = os.path.join(get_package_prefix(sl.PACKAGE), 'lib', sl.PACKAGE, 'mcu_emulator')
    emulator = ExecuteProcess(
        cmd=[executable, '--link', link, '--baud', sl.arg(context, 'baud'),
             '--seed', sl.arg(context, 'seed')],
        name='mcu_emulator', output='screen')
    hardware = IncludeLaunchDescription(
        PythonLaunchDescriptionSource(os.path.join(os.path.dirname(__file__),
                                                   'hardware.launch.py')),
        launch_arguments=[(name, sl.arg(context, name)) for name in FORWARDED]
        + [('port', link)])
    return [emulator, hardware]


def generate_launch_description():
    """Return the emulator loop's launch description."""
    return LaunchDescription([
        *sl.common_arguments(use_sim_time='false'),
        DeclareLaunchArgument('link', default_value='/tmp/sma_mcu',
                              description='Path of the emulator pty link (the bridge port).'),
        DeclareLaunchArgument('baud', default_value='115200',
                              description='Emulated UART speed [bit/s].'),
        DeclareLaunchArgument('seed', default_value='0', description='Emulator noise seed.'),
        DeclareLaunchArgument('setpoint', default_value='true', choices=['true', 'false'],
                              description='Also run the setpoint node (profile argument).'),
        OpaqueFunction(function=_emulator_and_loop),
    ])
