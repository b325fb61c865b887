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
ROS 2 nodes (thin wrappers around the core and sma_actuator.control).

plant_sim: simulated actuator; controller: pi / pi_inverse / on_off; setpoint: profiles;
hardware_bridge: the serial rig; recorder and replay: MCAP bags. The one ROS helper layer
they all use:

- common: topic names, QoS profiles, config files;
- ros_params: the parameter table of each node (declaration with descriptors, checks);
- ros_diagnostics: every DiagnosticStatus on /diagnostics;
- ros_console: --help, bad input (exit 2), parameter-source warnings, stop signals, spin;
- ros_bag: the rclpy side of recording and replay (sma_actuator.bag imports no ROS).
"""
