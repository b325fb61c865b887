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
Build the launch_ros actions shared by the launch files in launch/ (docs/launch.md).

Each node gets, in this order (later entries win): its installed config YAML
(share/sma_actuator/config/<node>.yaml), the launch arguments that were given (mode,
profile, use_sim_time, ...) and the optional `params_file` (a ROS parameter file with
`/**:` or per-node sections, e.g. `/**/controller:`).
"""
from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, TYPE_CHECKING

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument
from launch_ros.actions import Node

if TYPE_CHECKING:
    from launch import LaunchContext

PACKAGE = 'sma_actuator'
MODES = ('pi', 'pi_inverse', 'on_off')
PROFILES = ('constant', 'step', 'ramp', 'sine', 'square', 'chirp')


def common_arguments(use_sim_time: str = 'false') -> List[DeclareLaunchArgument]:
    """Return the launch arguments every launch file declares."""
    return [
        DeclareLaunchArgument('namespace', default_value='sma', description=(
            'Namespace of the actuator: its topics are <namespace>/setpoint, /duty, '
            '/joint_states, /wire_a/temperature, ...')),
        DeclareLaunchArgument('mode', default_value='', choices=['', *MODES], description=(
            f'Controller mode ({", ".join(MODES)}); empty: from the params files.')),
        DeclareLaunchArgument('profile', default_value='', choices=['', *PROFILES],
                              description=(
            f'Setpoint profile ({", ".join(PROFILES)}); empty: from the params files.')),
        DeclareLaunchArgument('model_file', default_value='', description=(
            "The controller's model file (sma-model fit --out: the fitted rig); empty: from "
            'the params files (config/controller_model.yaml).')),
        DeclareLaunchArgument('params_file', default_value='', description=(
            'Extra ROS parameter YAML applied to every node after its installed '
            'config/<node>.yaml (sections /** or /**/<node>); empty: none.')),
        DeclareLaunchArgument('use_sim_time', default_value=use_sim_time,
                              choices=['true', 'false'],
                              description='Run the nodes on /clock.'),
        DeclareLaunchArgument('record', default_value='false', choices=['true', 'false'],
                              description="Record the namespace's topics and /diagnostics."),
        DeclareLaunchArgument('bag_path', default_value='', description=(
            'Recorder bag directory; empty: runs/<run name and date> (config/recorder.yaml).')),
        DeclareLaunchArgument('log_level', default_value='info',
                              choices=['debug', 'info', 'warn', 'error', 'fatal'],
                              description='Log level of every node.'),
    ]


def arg(context: LaunchContext, name: str) -> str:
    """Return the value of launch argument `name` (a string)."""
    return context.launch_configurations.get(name, '')


def flag(context: LaunchContext, name: str) -> bool:
    """Return launch argument `name` as a bool ('true'/'false')."""
    return arg(context, name).lower() == 'true'


def config_file(name: str) -> str:
    """Return the installed config/<name> path."""
    return os.path.join(get_package_share_directory(PACKAGE), 'config', name)


def node(context: LaunchContext, executable: str, overrides: Optional[Dict[str, Any]] = None,
         config: Optional[str] = None) -> Node:
    """
    Return a launch_ros Node for `executable` in the launch's namespace.

    Parameters: the installed config/<config or executable>.yaml, then `overrides` (only
    the non-empty ones), use_sim_time, then params_file when given.
    """
    parameters = [config_file(f'{config or executable}.yaml'),
                  {k: v for k, v in (overrides or {}).items() if v != ''},
                  {'use_sim_time': flag(context, 'use_sim_time')}]
    if arg(context, 'params_file'):
        parameters.append(arg(context, 'params_file'))
    return Node(package=PACKAGE, executable=executable, name=executable,
                namespace=arg(context, 'namespace'), parameters=parameters,
                ros_arguments=['--log-level', arg(context, 'log_level')],
                output='screen', emulate_tty=False)


def controller(context: LaunchContext) -> Node:
    """Return the controller Node (mode and model file from the `mode`, `model_file` args)."""
    return node(context, 'controller', {'mode': arg(context, 'mode'),
                                        'model_file': arg(context, 'model_file')})


def setpoint(context: LaunchContext) -> Node:
    """Return the setpoint Node (profile from the `profile` argument)."""
    return node(context, 'setpoint', {'profile': arg(context, 'profile')})


def recorder(context: LaunchContext) -> List[Node]:
    """Return the recorder Node when `record` is true (as a list: [] or [Node])."""
    if not flag(context, 'record'):
        return []
    return [node(context, 'recorder', {'bag_path': arg(context, 'bag_path')})]
