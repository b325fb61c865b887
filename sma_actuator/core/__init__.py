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
Pure numerical core (no ROS): hysteresis, thermal dynamics, actuator, identification, model file.

Equation numbers refer to Solc & Vasina, "Modeling and Control of SMA Actuator"
(shared/reference): (1)-(2) cosine major loop, (3)-(4) Preisach, (5) Prandtl-Ishlinskii,
(6) modified PI (backlash with saturation), (7) wire thermal dynamics.
"""
