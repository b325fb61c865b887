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

"""plant_sim + controller + setpoint through real topics (accelerated sim time, one executor)."""
import numpy as np
import pytest
from sma_actuator.control.metrics import summarize

in_process = pytest.importorskip('sma_actuator.in_process')


@pytest.mark.slow
@pytest.mark.parametrize('mode', ['pi', 'pi_inverse'])
def test_loop_settles_on_a_step(ros_context, mode):
    trace = in_process.run_closed_loop(
        ros_context, {'profile': 'step', 'amplitude': 0.4, 'offset': 0.0, 'delay_s': 1.0}, 12.0,
        mode=mode, real_time_factor=100.0)
    a = trace.arrays()
    t = a['time_s'] - a['time_s'][0]
    m = summarize(t, a['setpoint'], a['position'], tolerance_rad=0.02, t_start=1.0)
    assert m['settling_time'] is not None and m['settling_time'] < 8.0
    # sim time really advanced in 25 ms steps and the wires stayed in the safe range
    assert np.allclose(np.diff(a['time_s']), 0.025, atol=1e-6)
    assert np.nanmax(a['theta']) < 110.0
    assert (np.minimum(a['duty'][:, 0], a['duty'][:, 1]) <= 0.05).all()


@pytest.mark.slow
@pytest.mark.parametrize('mode, atol_rad', [('pi', 0.01), ('pi_inverse', 0.0)])
def test_the_nodes_close_the_loop_as_the_ros_free_loop_does_sample_for_sample(
        ros_context, mode, atol_rad):
    # plant_sim and the controller node, on lockstep sim time, against the core controller
    # on the core plant (`control.closed_loop`). pi_inverse: the same readings to the last
    # ADC count; the plant's dead-time interlock and the controller's release a wire on the
    # same sample (one sample later in the plant and the controller's model heats a wire
    # the plant holds off, its estimate runs 1 K ahead and the step creeps: 0.9 s to rise).
    # pi keeps the dead time too (the plant holds nothing); its integral sums the stamps'
    # dt, 0.025 s to within 1e-15 s, which flips an ADC count now and then: within 17
    # counts (0.01 rad)
    from sma_actuator.control.closed_loop import CorePlant, run_tracking
    from sma_actuator.control.law import ControllerCore, ControllerSettings
    from sma_actuator.core.actuator import ActuatorParams
    from sma_actuator.core.model_file import load_model
    from sma_actuator.nodes.common import config_path
    from sma_actuator.profiles import Profile
    step = {'profile': 'step', 'amplitude': 0.4, 'offset': 0.0, 'delay_s': 1.0}
    trace = in_process.run_closed_loop(ros_context, step, 6.0, mode=mode,
                                       real_time_factor=100.0, plant={'seed': 0})
    nodes = trace.arrays()['position']
    model = load_model(config_path('controller_model.yaml'))
    core = ControllerCore(model, ControllerSettings(mode))
    alone = run_tracking(core, CorePlant(ActuatorParams(), seed=0),
                         Profile('step', 0.4, delay_s=1.0), 6.0).position
    n = min(len(nodes), len(alone) - 1)
    assert n > 200 and np.ptp(nodes[:n]) > 0.35
    # the probe's first sample is the plant's reading before the first step
    np.testing.assert_allclose(nodes[1:n], alone[2:n + 1], rtol=0.0, atol=atol_rad)
