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
Node parameters.

The config YAMLs load with --params-file, runtime changes are validated, and the setpoint one-shot
mode publishes one value and exits.
"""
import os
from pathlib import Path
import subprocess
import sys
import time

from conftest import NOTICE_S, spin_until
import pytest

rclpy = pytest.importorskip('rclpy')
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sma_actuator.core.actuator import ActuatorParams, PARAMETERS  # noqa: E402
from sma_actuator.nodes import common as c  # noqa: E402
from sma_actuator.nodes.controller import Controller  # noqa: E402
from sma_actuator.nodes.plant_sim import EFFECTS, PlantSim  # noqa: E402
from sma_actuator.nodes.setpoint import Setpoint  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
import yaml  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / 'config'
NODES = {'plant_sim': PlantSim, 'controller': Controller, 'setpoint': Setpoint}


@pytest.mark.parametrize('name', sorted(NODES))
def test_config_yaml_loads_with_params_file_and_sets_every_declared_value(name, ros_domain_id):
    path = CONFIG / f'{name}.yaml'
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=ros_domain_id,
               args=['--ros-args', '--params-file', str(path)])
    try:
        node = NODES[name](context=context)
        try:
            expected = yaml.safe_load(path.read_text())['/**']['ros__parameters']
            for key, value in expected.items():
                assert node.get_parameter(key).value == value, key
            declared = set(node._parameters) - {'use_sim_time', 'start_type_description_service'}
            assert declared == set(expected), 'YAML and declared parameters differ'
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_every_actuator_effect_is_a_plant_parameter():
    physical = {'length_m', 'resistance_ohm_per_m', 'supply_v', 'current_limit_a',
                'heat_capacity_j_per_k', 'conductance_w_per_k', 'ambient_c', 'stroke_rad',
                'offset_rad', 'sensor_centre_rad', 'sensor_half_span_rad', 'hysteresis'}
    effects = set(ActuatorParams.__dataclass_fields__) - physical
    assert effects == {name for name, *_ in EFFECTS}
    assert effects == {name for name, spec in PARAMETERS.items() if spec.effect}


def test_every_plant_effect_range_lies_within_the_workbench_fit_bounds():
    # data made with any plant setting can be fitted by `sma-model` (same parameter names)
    from sma_actuator.workbench.effects import BUILTIN
    bounds = {k: v for cls in BUILTIN.values() for k, v in cls.parameters.items()}
    for name, lo, hi, _ in EFFECTS:
        spec = PARAMETERS[name]
        assert bounds[name] == spec.fit, name     # the catalog fits the declared bounds
        assert spec.fit_covers(lo) and spec.fit_covers(hi), (name, lo, hi, spec.fit)


def test_plant_effect_parameters_reach_the_model(ros_context):
    plant = PlantSim(context=ros_context, parameter_overrides=[
        Parameter('delay_s', value=0.3), Parameter('gain_ratio_b', value=1.4)])
    try:
        assert plant.params.delay_s == 0.3 and plant.params.gain_ratio_b == 1.4
        assert plant.actuator.params is plant.params
        with pytest.raises(Exception):   # out of its declared range
            PlantSim(context=ros_context, parameter_overrides=[
                Parameter('phase_kappa', value=5.0)])
    finally:
        plant.destroy_node()


def test_controller_settings_change_at_runtime_and_invalid_ones_are_refused(ros_context):
    ctrl = Controller(context=ros_context)
    try:
        ok = ctrl.set_parameters([Parameter('mode', value='pi_inverse'),
                                  Parameter('kp', value=5.0)])
        assert all(r.successful for r in ok)
        assert ctrl.core.settings.mode == 'pi_inverse' and ctrl.core.pi.kp == 5.0
        bad = ctrl.set_parameters([Parameter('mode', value='bang_bang')])
        assert not bad[0].successful and ctrl.core.settings.mode == 'pi_inverse'
        out_of_range = ctrl.set_parameters([Parameter('kp', value=-2.0)])
        assert not out_of_range[0].successful and ctrl.core.pi.kp == 5.0
        read_only = ctrl.set_parameters([Parameter('period_s', value=0.01)])
        assert not read_only[0].successful
    finally:
        ctrl.destroy_node()


@pytest.mark.slow
def test_setpoint_one_shot_publishes_one_value_and_exits(ros_context, ros_domain_id):
    node = rclpy.create_node('listener', context=ros_context, namespace=c.NAMESPACE)
    got = []
    node.create_subscription(Float64, c.SETPOINT, lambda m: got.append(m.data), c.COMMAND_QOS)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    proc = subprocess.Popen([sys.executable, '-m', 'sma_actuator.nodes.setpoint', '--ros-args',
                             '-p', 'one_shot:=true', '-p', 'offset:=0.3'],
                            env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + NOTICE_S
        while proc.poll() is None and time.monotonic() < deadline:
            ex.spin_once(timeout_sec=0.05)
        assert spin_until(ex, lambda: got)
        spin_until(ex, lambda: False, 0.5)            # a second value would show up by now
        assert proc.returncode == 0
        assert got == [0.3]
    finally:
        if proc.poll() is None:
            proc.kill()
        ex.shutdown()
        node.destroy_node()


def test_every_node_reports_on_diagnostics(ros_context):
    from diagnostic_msgs.msg import DiagnosticArray
    nodes = [PlantSim(context=ros_context), Controller(context=ros_context),
             Setpoint(context=ros_context)]
    listener = rclpy.create_node('diag_listener', context=ros_context)
    names = set()
    listener.create_subscription(DiagnosticArray, c.DIAGNOSTICS,
                                 lambda m: names.update(s.name.split(':')[0] for s in m.status),
                                 c.DIAGNOSTICS_QOS)
    ex = SingleThreadedExecutor(context=ros_context)
    for n in nodes + [listener]:
        ex.add_node(n)
    try:
        spin_until(ex, lambda: {'plant_sim', 'controller', 'setpoint'} <= names)
        assert {'plant_sim', 'controller', 'setpoint'} <= names
    finally:
        ex.shutdown()
        for n in nodes + [listener]:
            n.destroy_node()


def test_plant_follows_the_ambient_topic_and_rejects_a_bad_ambient(ros_context):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from sensor_msgs.msg import Temperature
    plant = PlantSim(context=ros_context, parameter_overrides=[
        Parameter('use_ambient_topic', value=True), Parameter('accelerated', value=True),
        Parameter('real_time_factor', value=50.0)])
    node = rclpy.create_node('ambient_source', context=ros_context, namespace=c.NAMESPACE)
    pub = node.create_publisher(Temperature, c.AMBIENT_TEMPERATURE, c.SENSOR_QOS)
    warns = []
    node.create_subscription(DiagnosticArray, c.DIAGNOSTICS,
                             lambda m: warns.extend(s.message for s in m.status
                                                    if s.level == DiagnosticStatus.WARN),
                             c.DIAGNOSTICS_QOS)
    ex = SingleThreadedExecutor(context=ros_context)
    for n in (plant, node):
        ex.add_node(n)
    try:
        spin_until(ex, lambda: pub.get_subscription_count() > 0)
        pub.publish(Temperature(temperature=40.0))
        pub.publish(Temperature(temperature=float('nan')))
        spin_until(ex, lambda: plant.sim_time >= 10.0)   # sim time: the wall time is the host's
        assert plant.ambient_c == 40.0                  # NaN rejected, 40 kept
        assert any('rejected ambient' in w for w in warns)
        # zero duty: both wires relax to the new ambient (T = 2 s, 10 s elapsed)
        assert plant.actuator.temperature_c == pytest.approx([40.0, 40.0], abs=0.5)
    finally:
        ex.shutdown()
        for n in (plant, node):
            n.destroy_node()


def test_accelerated_plant_waits_for_its_subscribers_and_stops_at_duration(ros_context):
    # a recording of fixed sim-time length (scripts/walkthrough.sh)
    plant = PlantSim(context=ros_context, parameter_overrides=[
        Parameter('accelerated', value=True), Parameter('real_time_factor', value=50.0),
        Parameter('start_subscribers', value=1), Parameter('duration_s', value=2.0)])
    reader = rclpy.create_node('reader', namespace=c.NAMESPACE, context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(plant)
    try:
        deadline = time.monotonic() + 0.5
        while time.monotonic() < deadline:
            ex.spin_once(timeout_sec=0.05)
        assert plant.sim_time == 0.0 and not plant.finished      # nobody listens yet
        from sensor_msgs.msg import JointState
        reader.create_subscription(JointState, c.JOINT_STATES, lambda m: None, c.SENSOR_QOS)
        deadline = time.monotonic() + 30
        while not plant.finished and time.monotonic() < deadline:
            ex.spin_once(timeout_sec=0.05)
        assert plant.finished and plant.sim_time == pytest.approx(2.0)
        for _ in range(20):
            ex.spin_once(timeout_sec=0.01)
        assert plant.sim_time == pytest.approx(2.0)               # no step past duration_s
    finally:
        ex.shutdown()
        reader.destroy_node()
        plant.destroy_node()
