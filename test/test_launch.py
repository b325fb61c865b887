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
The launch files, run by the real launch system (launch.LaunchService).

Each test includes launch/<file> as `ros2 launch` would, watches the actuator's topics from
a probe node until the shaft reaches a step setpoint (judged from the messages), then shuts
the launch down and checks that every process exited with 0, collected from OnProcessExit
events. Waits are bounded only to stop a broken build from hanging.

A node ended by its stop grace while rclpy destroyed it (the middleware's teardown hang,
after its last word) counts as exit 0: `support.stopping`.
"""
import os
from pathlib import Path
import sys
import threading
import time

import numpy as np
import pytest
from support.stopping import teardown_hung

# slow: each launch runs several node processes (quick run: -m "not slow")
pytestmark = pytest.mark.slow
UNKNOWN_NAMESPACE = '_NODE_NAMESPACE_UNKNOWN_'

pytest.importorskip('launch')
pytest.importorskip('launch_ros')

ROOT = Path(__file__).resolve().parents[1]
STEP_RAD = 0.3
TOLERANCE_RAD = 0.03
BOUND_S = 240.0
# longest wait for the probe to see every endpoint of the loop, named, in the graph [s]
GRAPH_NAMES_S = 30.0
# a recording run goes on until the recorder has counted this many messages of each topic
RECORDED = {'/sma/duty': 10, '/sma/setpoint': 1, '/sma/joint_states': 10}


@pytest.fixture(autouse=True)
def ament_prefix(monkeypatch):
    """Make the venv an ament prefix, as scripts/bootstrap.sh does (needed by launch_ros)."""
    from ament_index_python.packages import get_package_prefix, PackageNotFoundError
    paths = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    if sys.prefix not in paths:
        monkeypatch.setenv('AMENT_PREFIX_PATH', os.pathsep.join([sys.prefix] + paths))
    try:
        prefix = Path(get_package_prefix('sma_actuator'))
    except PackageNotFoundError:
        pytest.skip('sma_actuator is not on an ament index (source scripts/bootstrap.sh)')
    if not (prefix / 'share' / 'sma_actuator' / 'launch' / 'sim.launch.py').is_file():
        pytest.skip(f'{prefix} has no installed launch files (source scripts/bootstrap.sh)')


def _step_params(tmp_path, steps):
    """Write a params file: setpoint of each namespace a step to `steps[ns]` [rad]."""
    text = ''
    for ns, target in steps.items():
        text += (f'/{ns}/setpoint:\n  ros__parameters:\n    profile: step\n'
                 f'    amplitude: {target}\n    offset: 0.0\n    delay_s: 1.0\n')
    path = tmp_path / 'step.yaml'
    path.write_text(text)
    return str(path)


class Watcher:
    """
    Probe node: the latest setpoint and shaft angle of each namespace, from the topics.

    It also keeps the per-topic message counts that a recorder reports on /diagnostics
    (``count <topic>`` values), so a run can go on until the bag holds what it must.
    """

    def __init__(self, domain_id, namespaces, recorded=None):
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64

        from sma_actuator.nodes import common as c
        self.rclpy = rclpy
        self.context = rclpy.context.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node('launch_watcher', context=self.context)
        self.setpoint = dict.fromkeys(namespaces)
        self.reached = dict.fromkeys(namespaces, False)
        self.positions = {ns: [] for ns in namespaces}
        self.needed = dict(recorded or {})
        self.recorded = dict.fromkeys(self.needed, 0)
        if self.needed:
            self.node.create_subscription(DiagnosticArray, c.DIAGNOSTICS, self._diagnostics,
                                          c.DIAGNOSTICS_QOS)
        for ns in namespaces:
            self.node.create_subscription(
                Float64, f'/{ns}/{c.SETPOINT}', lambda m, ns=ns: self._setpoint(ns, m.data),
                c.COMMAND_QOS)
            self.node.create_subscription(
                JointState, f'/{ns}/{c.JOINT_STATES}',
                lambda m, ns=ns: self._joint_state(ns, m.position[0]), c.SENSOR_QOS)

    def _setpoint(self, ns, value):
        self.setpoint[ns] = value

    def _joint_state(self, ns, position):
        self.positions[ns].append(position)
        target = self.setpoint[ns]
        if target is not None and target != 0.0 and abs(position - target) < TOLERANCE_RAD:
            self.reached[ns] = True

    def _diagnostics(self, msg):
        for status in msg.status:
            for item in status.values:
                topic = item.key.removeprefix('count ')
                if topic in self.recorded and item.key != topic:
                    self.recorded[topic] = max(self.recorded[topic], int(item.value))

    def done(self):
        # the recorder discovers a publisher some time after it starts (later still on a
        # busy machine): a recorded run goes on until the bag holds every topic it checks
        return all(self.reached.values()) and all(
            self.recorded[topic] >= count for topic, count in self.needed.items())

    def close(self):
        self.node.destroy_node()
        self.rclpy.try_shutdown(context=self.context)


def run_launch(file, arguments, domain_id, namespaces, extra_check=None, recorded=None):
    """
    Run launch/<file> until every namespace's shaft reached its step setpoint.

    With `recorded` ({topic: messages}), also until a recorder has counted that many.

    Returns (watcher, [(process name, exit code)], what extra_check(node) returned while
    the loop was running).
    """
    from ament_index_python.packages import get_package_share_directory
    from launch import LaunchDescription, LaunchService
    from launch.actions import (IncludeLaunchDescription, RegisterEventHandler,
                                SetLaunchConfiguration)
    from launch.event_handlers import OnProcessExit, OnProcessIO
    from launch.launch_description_sources import PythonLaunchDescriptionSource

    path = Path(get_package_share_directory('sma_actuator')) / 'launch' / file
    exits, stderr = [], {}
    includes = [IncludeLaunchDescription(PythonLaunchDescriptionSource(str(path)),
                                         launch_arguments=list(args.items()))
                for args in arguments]
    description = LaunchDescription([
        # a loaded machine may need longer than the default 5 s to stop a Python node
        SetLaunchConfiguration('sigterm_timeout', '30'),
        SetLaunchConfiguration('sigkill_timeout', '30'),
        RegisterEventHandler(OnProcessIO(on_stderr=lambda event: stderr.setdefault(
            event.action.name, []).append(event.text.decode(errors='replace')))),
        RegisterEventHandler(OnProcessExit(on_exit=lambda event, _: exits.append(
            (event.action.name.rsplit('-', 1)[0], 0 if teardown_hung(
                event.returncode, ''.join(stderr.get(event.action.name, [])))
             else event.returncode)))),
        *includes])
    service = LaunchService()
    service.include_launch_description(description)
    watcher = Watcher(domain_id, namespaces, recorded)
    extra = {}

    def watch():
        from rclpy.executors import SingleThreadedExecutor
        executor = SingleThreadedExecutor(context=watcher.context)
        executor.add_node(watcher.node)
        deadline = time.monotonic() + BOUND_S
        try:
            while not watcher.done() and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.1)
            if extra_check and watcher.done():
                extra['result'] = extra_check(watcher.node)
        finally:   # a failing check must not leave the launch running
            service.shutdown()

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    try:
        code = service.run()   # the main thread: LaunchService refuses any other
    finally:
        thread.join(BOUND_S)
        watcher.close()
    assert code == 0, f'launch returned {code}'
    return watcher, exits, extra.get('result')


def _model_files(node):
    """Return {node: its model_file parameter} of the controller and plant in /sma."""
    from rcl_interfaces.srv import GetParameters
    from rclpy.executors import SingleThreadedExecutor
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    out = {}
    for name in ('controller', 'plant_sim'):
        client = node.create_client(GetParameters, f'/sma/{name}/get_parameters')
        if client.wait_for_service(timeout_sec=GRAPH_NAMES_S):
            future = client.call_async(GetParameters.Request(names=['model_file']))
            executor.spin_until_future_complete(future, timeout_sec=GRAPH_NAMES_S)
            if future.done():
                out[name] = future.result().values[0].string_value
        node.destroy_client(client)
    executor.remove_node(node)
    return out


def test_sim_launch_closes_the_loop_records_and_stops_cleanly(tmp_path, ros_domain_id):
    # a rig's fitted model (here a copy of the controller's default) reaches both nodes
    from sma_actuator.bag.arrays import load_run
    bag = tmp_path / 'bag'
    model = tmp_path / 'rig.yaml'
    model.write_text((ROOT / 'config' / 'controller_model.yaml').read_text())
    watcher, exits, model_files = run_launch('sim.launch.py', [{
        'params_file': _step_params(tmp_path, {'sma': STEP_RAD}), 'mode': 'pi',
        'record': 'true', 'bag_path': str(bag), 'real_time_factor': '5.0',
        'model_file': str(model), 'plant_model_file': str(model)}],
        ros_domain_id, ['sma'], extra_check=_model_files, recorded=RECORDED)
    assert model_files == {'controller': str(model), 'plant_sim': str(model)}
    assert watcher.reached == {'sma': True}, watcher.positions['sma'][-5:]
    assert all(watcher.recorded[t] >= n for t, n in RECORDED.items()), watcher.recorded
    assert sorted(exits) == [('controller', 0), ('plant_sim', 0), ('recorder', 0),
                             ('setpoint', 0)]
    run = load_run(bag)
    assert run['setpoint'][-1] == pytest.approx(STEP_RAD)
    assert abs(run['position'] - STEP_RAD).min() < TOLERANCE_RAD
    assert run['duty_a'].max() > 0.0    # the controller's heating is in the bag


def test_two_actuators_side_by_side_do_not_cross_talk(tmp_path, ros_domain_id):
    params = _step_params(tmp_path, {'left': STEP_RAD, 'right': -STEP_RAD})
    # two plants cannot both own /clock: the pair runs on the wall clock
    common = {'params_file': params, 'use_sim_time': 'false', 'mode': 'pi'}

    def snapshot(node):
        return {topic: sorted({(i.node_namespace, i.node_name) for i in (
            node.get_publishers_info_by_topic(topic)
            + node.get_subscriptions_info_by_topic(topic))})
            for ns in ('left', 'right') for topic in (f'/{ns}/duty', f'/{ns}/joint_states')}

    def settled(seen):
        return all({'controller', 'plant_sim'} <= {name for _, name in endpoints}
                   and UNKNOWN_NAMESPACE not in {ns for ns, _ in endpoints}
                   for endpoints in seen.values())

    def graph(node):
        # the probe learns of other nodes' endpoints, and DDS names their nodes, some time
        # after the loop runs through them (later still on a busy machine): look again until
        # every topic shows its controller and plant and every endpoint is named, bounded
        deadline = time.monotonic() + GRAPH_NAMES_S
        seen = snapshot(node)
        while time.monotonic() < deadline and not settled(seen):
            time.sleep(0.2)
            seen = snapshot(node)
        return seen

    watcher, exits, seen = run_launch(
        'sim.launch.py', [{'namespace': 'left', **common}, {'namespace': 'right', **common}],
        ros_domain_id, ['left', 'right'], extra_check=graph)
    tails = {ns: positions[-5:] for ns, positions in watcher.positions.items()}
    assert watcher.reached == {'left': True, 'right': True}, tails
    assert max(watcher.positions['left']) > STEP_RAD - TOLERANCE_RAD, tails
    # the right shaft never went left
    assert max(watcher.positions['right']) < 0.05, max(watcher.positions['right'])
    for topic, endpoints in seen.items():
        ns = topic.split('/')[1]
        # an endpoint whose node DDS has not yet named (or no longer names) is reported as
        # _NODE_NAMESPACE_UNKNOWN_: it belongs to no namespace, so it is no cross-talk
        named = {n for n, _ in endpoints} - {'/', UNKNOWN_NAMESPACE}
        assert named == {f'/{ns}'}, (topic, endpoints)
        assert {'controller', 'plant_sim'} <= {name for _, name in endpoints}, topic
    assert sorted(exits) == sorted([('controller', 0), ('plant_sim', 0), ('setpoint', 0)] * 2)


def test_emulator_launch_closes_the_loop_through_bridge_and_emulator(tmp_path, ros_domain_id):
    from sma_actuator.bag.arrays import load_run
    bag = tmp_path / 'bag'
    recorded = {**RECORDED, '/sma/applied_duty': 10}
    watcher, exits, _ = run_launch('emulator.launch.py', [{
        'params_file': _step_params(tmp_path, {'sma': STEP_RAD}), 'mode': 'pi',
        'link': str(tmp_path / 'mcu'), 'baud': '1000000', 'record': 'true',
        'bag_path': str(bag)}], ros_domain_id, ['sma'], recorded=recorded)
    assert watcher.reached == {'sma': True}, watcher.positions['sma'][-5:]
    assert sorted(exits) == [('controller', 0), ('hardware_bridge', 0), ('mcu_emulator', 0),
                             ('recorder', 0), ('setpoint', 0)]
    # the bag's duty is the one the bridge sent to the emulated MCU
    notes = []
    run = load_run(bag, notes=notes)
    assert f'{bag}: duty read from /sma/applied_duty, as the hardware applied it, not from the ' \
           'commands on /sma/duty' in notes
    assert run['duty_a'].max() > 0.0 and not np.any((run['duty_a'] > 0) & (run['duty_b'] > 0))
