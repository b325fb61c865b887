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

The public API, the one a ROS-free user or a test needs::

    from sma_actuator.control import ControllerCore, ControllerSettings, load_model
    model = load_model('fitted.yaml')              # written by `sma-model fit --out`
    ctrl = ControllerCore(model, ControllerSettings(mode='pi_inverse'))
    out = ctrl.step(setpoint_rad, measured_rad, dt_s, ambient_c)   # -> out.duty_a, out.duty_b

Modules:

* `pi`: discrete PI with anti-windup (the paper's 25 ms PI).
* `tuning`: default PI gains from the fitted model (SIMC rules).
* `split`: antagonistic split of a signed command into two wire duties.
* `estimator`: wire state estimate from the core model, Smith prediction of the
  measurement over the delay, drift (offset / stroke) correction.
* `guard`: thermal guard (duty limits from the estimated temperatures).
* `feedforward`: inverse compensation sensor^-1, per-wire H^-1 and thermal inverse
  (mode `pi_inverse`).
* `handover`: pi_inverse at a zero crossing: the incoming wire heated early, the
  outgoing one let go, never both within the interlock's dead time.
* `on_off`: the paper's fully-heated / fully-cooled relay mode.
* `law`: the control law, `ControllerCore`: the three modes assembled into one step function.
* `inputs`: validation of setpoints and duties (reject, keep the last valid value).
* `metrics`: rms / max error and settling time of a tracking run.
* `interlock`: the dead-time rule between the two wires (also used by plant_sim and the bridge).
* `closed_loop`: a `ControllerCore` against any plant, sample by sample (benchmarks, tests).

`load_model` is `core.model_file.load_model`, re-exported here: the package's one model
file is read and written in `core.model_file` (docs/workbench.md, "The model file").
"""
from .law import ControllerCore, ControllerSettings, ControlStep
from ..core.model_file import load_model

__all__ = ['ControllerCore', 'ControllerSettings', 'ControlStep', 'load_model']
