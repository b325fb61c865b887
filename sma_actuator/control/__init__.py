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
ROS-free control logic of the actuator (unit-tested without ROS; the nodes are thin wrappers).

* `pi`: discrete PI with anti-windup (the paper's 25 ms PI).
* `split`: antagonistic split of a signed command into two wire duties.
* `estimator`: wire temperature/contraction estimate from the core model.
* `guard`: thermal guard (duty limits from the estimated temperatures).
* `feedforward`: inverse compensation H^-1 + static thermal map (mode `pi_inverse`).
* `on_off`: the paper's fully-heated / fully-cooled relay mode.
* `core`: `ControllerCore`, the three modes assembled into one step function.
* `inputs`: validation of setpoints and duties (reject, keep the last valid value).
* `metrics`: rms / max error and settling time of a tracking run.
* `excitation`: open-loop duty sequences for identification runs.
"""
