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
Launch the simulated closed loop: plant_sim, controller, setpoint; recorder with record:=true.

    ros2 launch sma_actuator sim.launch.py namespace:=left profile:=step record:=true
    ros2 launch sma_actuator sim.launch.py model_file:=m.yaml plant_model_file:=m.yaml

With use_sim_time:=true (the default) the plant owns the time: it steps in lockstep with the
controller (each step waits for the duty reply to the last joint state) and publishes
/clock at up to real_time_factor times real time, so results do not depend on host load.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction

from sma_actuator import launching as sl


def _nodes(context):
    sim = sl.flag(context, 'use_sim_time')
    plant = sl.node(context, 'plant_sim', {
        'accelerated': sim, 'lockstep': sim,
        'real_time_factor': float(sl.arg(context, 'real_time_factor')),
        'model_file': sl.arg(context, 'plant_model_file')})
    return [plant, sl.controller(context), sl.setpoint(context), *sl.recorder(context)]


def generate_launch_description():
    """Return the simulated loop's launch description."""
    return LaunchDescription([
        *sl.common_arguments(use_sim_time='true'),
        DeclareLaunchArgument('real_time_factor', default_value='1.0', description=(
            'Sim seconds per wall second with use_sim_time (an upper bound: lockstep waits '
            'for the controller).')),
        DeclareLaunchArgument('plant_model_file', default_value='', description=(
            "The simulated plant's model file (sma-model fit --out: the fitted rig); empty: "
            'from the params files (config/plant_sim.yaml, the neutral plant).')),
        OpaqueFunction(function=_nodes),
    ])
