"""plant_sim + controller + setpoint through real topics (accelerated sim time, one executor)."""
import numpy as np
import pytest
from sma_actuator.control.metrics import summarize

harness = pytest.importorskip('sma_actuator.nodes.harness')


@pytest.mark.parametrize('mode', ['pi', 'pi_inverse'])
def test_loop_settles_on_a_step(ros_context, mode):
    trace = harness.run_closed_loop(
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
