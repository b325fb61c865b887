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
Node command lines (issue 16) and params-file warnings (issue 13 item 10).

Every console script answers --help with its declared parameters and starts nothing; an
integer is accepted for a double; a bad value ends in one stderr line and exit 2; unknown
parameters and params files with nothing for the node are warned about.
"""
import importlib
import os
from pathlib import Path
import re
import signal
import socket
import subprocess
import threading

from hardware_support import console_command
import pytest

rclpy = pytest.importorskip('rclpy')
from rclpy.parameter import Parameter  # noqa: E402, I100, I202

from sma_actuator.nodes import ros_console, ros_params  # noqa: E402, I100

NODES = {'plant_sim': 'plant_sim', 'controller': 'controller', 'setpoint': 'setpoint',
         'hardware_bridge': 'hardware_bridge', 'recorder': 'recorder', 'replay': 'replay'}
OTHER_SCRIPTS = {'mcu_emulator': 'sma_actuator.hardware.emulator',
                 'closed_loop_demo': 'sma_actuator.demo',
                 'model_figures': 'sma_actuator.figures'}
TIMEOUT_S = 60   # only to stop a broken build from hanging


def _command(name):
    module = OTHER_SCRIPTS.get(name, f'sma_actuator.nodes.{name}')
    return console_command(name, module)


def _run(name, *args, cwd=None, domain=None):
    env = dict(os.environ)
    if domain is not None:
        env['ROS_DOMAIN_ID'] = str(domain)
    return subprocess.run(_command(name) + list(args), capture_output=True, text=True,
                          timeout=TIMEOUT_S, cwd=cwd, env=env)


def _declared(node):
    names = node.get_parameters_by_prefix('')
    return {k: v for k, v in names.items() if k not in ros_params.RCLPY_PARAMETERS}


def _make_node(name, context, tmp_path):
    """Construct node `name` in-process with settings that open and write nothing real."""
    module = importlib.import_module(f'sma_actuator.nodes.{name}')
    if name == 'recorder':
        return module.RecorderNode(context=context, bag_path=str(tmp_path / 'bag'))
    if name == 'replay':
        from test_replay_node import _write_bag
        _write_bag(tmp_path / 'replay_bag', count=2)
        return module.ReplayNode(context=context, bag_path=str(tmp_path / 'replay_bag'))
    cls = {'plant_sim': 'PlantSim', 'controller': 'Controller', 'setpoint': 'Setpoint',
           'hardware_bridge': 'HardwareBridge'}[name]
    overrides = []
    if name == 'hardware_bridge':
        overrides = [Parameter('port', value='loop://')]
    return getattr(module, cls)(context=context, parameter_overrides=overrides)


@pytest.fixture
def listener():
    """Yield a TCP socket nobody should connect to: the bridge port of the --help tests."""
    sock = socket.socket()
    sock.bind(('127.0.0.1', 0))
    sock.listen(4)
    sock.setblocking(False)
    yield sock
    sock.close()


@pytest.mark.slow
@pytest.mark.parametrize('name', sorted(NODES))
def test_help_lists_every_declared_parameter_and_starts_nothing(name, tmp_path, listener,
                                                                ros_context):
    port = f'socket://127.0.0.1:{listener.getsockname()[1]}'
    # settings that would create a bag directory or open a port if the node started
    extra = ['--ros-args', '-p', f'port:={port}', '-p', f'output_dir:={tmp_path / "out"}',
             '-p', f'bag_path:={tmp_path / "bag"}']
    result = _run(name, '--help', *extra, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert 'Traceback' not in result.stderr
    text = result.stdout
    assert text.startswith(f'usage: {name} ')
    # the declarations the node really makes, with their types, ranges and defaults
    node = _make_node(name, ros_context, tmp_path / 'inproc')
    try:
        declared = _declared(node)
        descriptors = {n: node.describe_parameter(n) for n in declared}
    finally:
        node.destroy_node()
    assert declared
    for pname, descriptor in descriptors.items():
        line = next((ln for ln in text.splitlines() if ln.startswith(f'  {pname} (')), None)
        assert line is not None, f'{pname} missing from {name} --help'
        kind = {v: k for k, v in ros_params.KINDS.items()}[descriptor.type]
        assert f'({kind}, default ' in line, line
        for r in list(descriptor.floating_point_range) + list(descriptor.integer_range):
            assert f'range [{r.from_value:g}, {r.to_value:g}]' in line, line
        assert descriptor.description.split()[0] in text
    # started nothing: no file written, no connection to the port
    assert not (tmp_path / 'out').exists() and not (tmp_path / 'bag').exists()
    with pytest.raises(BlockingIOError):
        listener.accept()


@pytest.mark.slow
@pytest.mark.parametrize('name', sorted(OTHER_SCRIPTS))
def test_help_of_the_other_scripts_exits_0_and_writes_nothing(name, tmp_path):
    result = _run(name, '--help', cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert 'usage:' in result.stdout
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize('name, overrides, expected', [
    ('plant_sim', ['rate_hz:=50', 'real_time_factor:=20'], {'rate_hz': 50.0,
                                                            'real_time_factor': 20.0}),
    ('controller', ['kp:=5', 'feedback_timeout_s:=1'], {'kp': 5.0, 'feedback_timeout_s': 1.0}),
    ('setpoint', ['rate_hz:=50', 'amplitude:=1'], {'rate_hz': 50.0, 'amplitude': 1.0}),
    ('recorder', ['chunk_max_age_s:=2'], {'chunk_max_age_s': 2.0}),
])
def test_an_integer_is_accepted_for_a_double(name, overrides, expected, tmp_path,
                                             ros_domain_id):
    args = ['--ros-args'] + [a for o in overrides for a in ('-p', o)]
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=ros_domain_id, args=args)
    try:
        node = _make_node(name, context, tmp_path)
        try:
            for pname, value in expected.items():
                got = node.get_parameter(pname)
                assert got.type_ == Parameter.Type.DOUBLE and got.value == value
            # and at runtime (ros2 param set node kp 2), where the parameter is writable
            writable = [p for p in expected if not node.describe_parameter(p).read_only]
            for pname in writable:
                result = node.set_parameters([Parameter(pname, value=2)])[0]
                assert result.successful, result.reason
                assert node.get_parameter(pname).value == 2.0
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


@pytest.mark.parametrize('name, override, named', [
    ('plant_sim', 'rate_hz:=-5', 'rate_hz'),
    ('plant_sim', 'delay_s:=nan', 'delay_s'),
    ('controller', 'mode:=bogus', 'mode'),
    ('controller', 'kp:=abc', 'kp'),
    ('setpoint', 'profile:=zigzag', 'profile'),
    ('setpoint', 'one_shot:=3', 'one_shot'),
    ('hardware_bridge', 'baud:=12', 'baud'),
    ('recorder', 'compression:=rar', 'compression'),
    ('replay', 'rate:=0.0', 'rate'),
])
def test_a_bad_value_is_one_line_naming_the_parameter_and_exit_2(
        name, override, named, tmp_path, listener, ros_domain_id):
    port = f'socket://127.0.0.1:{listener.getsockname()[1]}'
    args = ['--ros-args', '-p', override]
    args += ['-p', f'port:={port}'] if name == 'hardware_bridge' else []
    args += ['-p', f'output_dir:={tmp_path}/out'] if name == 'recorder' else []
    result = _run(name, *args, cwd=tmp_path, domain=ros_domain_id)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f'{name}: parameter {named}: '), lines[0]
    assert 'allowed range' in lines[0] or 'one of' in lines[0] or 'is not' in lines[0]
    assert not (tmp_path / 'out').exists()


def test_an_argument_outside_ros_args_is_refused(tmp_path):
    result = _run('controller', '-p', 'kp:=1', cwd=tmp_path)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1
    assert 'after --ros-args' in result.stderr


def test_a_malformed_override_is_one_error_not_a_traceback(tmp_path):
    result = _run('controller', '--ros-args', '-p', 'kp:=[1, 2.5]', cwd=tmp_path)
    assert result.returncode == 2
    assert 'Traceback' not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert re.match(r'controller: bad --ros-args: .*kp:=\[1, 2.5\]', result.stderr)


def _run_until_logged(command, patterns, domain, timeout_s=TIMEOUT_S):
    """Start a node, collect its stderr until every pattern matched (or timeout), SIGINT it."""
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, env=dict(os.environ, ROS_DOMAIN_ID=str(domain)))
    lines, done = [], threading.Event()

    def read():
        for line in proc.stderr:
            lines.append(line)
            if all(any(re.search(p, ln) for ln in lines) for p in patterns):
                done.set()
        done.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    done.wait(timeout_s)
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=TIMEOUT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
    reader.join(5)
    return proc.returncode, ''.join(lines)


def test_misspelled_node_key_in_a_params_file_is_warned(tmp_path, ros_domain_id):
    # issue 13 item 10: the controller ran with duty_max 1.0 instead of the file's 0.1
    params = tmp_path / 'controller.yaml'
    params.write_text('/controler:\n  ros__parameters:\n    duty_max: 0.1\n')
    command = _command('controller') + ['--ros-args', '--params-file', str(params)]
    pattern = (rf'WARN.*params file {re.escape(str(params))} holds no parameters for node '
               r'/(\w+/)*controller; keys found: /controler')
    code, err = _run_until_logged(command, [pattern], ros_domain_id)
    assert re.search(pattern, err), err
    assert code == 0 and 'Traceback' not in err


def test_unknown_parameters_from_p_and_from_a_params_file_are_named(tmp_path, ros_domain_id):
    params = tmp_path / 'controller.yaml'
    params.write_text('/**:\n  ros__parameters:\n    duty_mx: 0.1\n    kp: 2.0\n')
    command = _command('controller') + ['--ros-args', '--params-file', str(params), '-p',
                                        'kpp:=3.0', '-p', 'ki:=1.0']
    pattern = (r'WARN.*does not declare: duty_mx \(params file '
               rf'{re.escape(str(params))}\), kpp \(-p\)')
    code, err = _run_until_logged(command, [pattern], ros_domain_id)
    assert re.search(pattern, err), err
    assert 'ki' not in err.split('does not declare')[1].split('\n')[0].replace('kpp', '')
    assert code == 0


def test_params_file_matching_follows_rcl_names(ros_context, tmp_path):
    good = tmp_path / 'good.yaml'
    good.write_text('sma:\n  controller:\n    ros__parameters:\n      kp: 2.0\n'
                    '/*/other:\n  ros__parameters:\n    kp: 1.0\n')
    node = rclpy.create_node('controller', namespace='/sma', context=ros_context)
    ros_params.declare_parameters(node, [ros_params.Param('kp', 1.0, 'Gain.')])
    warn = ros_console.warn_parameter_sources
    try:
        assert warn(node, ['--ros-args', '--params-file', str(good)]) == []
        wild = tmp_path / 'wild.yaml'
        wild.write_text('/**/controller:\n  ros__parameters:\n    kp: 2.0\n')
        assert warn(node, ['--ros-args', '--params-file', str(wild)]) == []
        bad = tmp_path / 'bad.yaml'
        bad.write_text('/left/controller:\n  ros__parameters:\n    kp: 2.0\n')
        (warning,) = warn(node, ['--ros-args', '--params-file', str(bad)])
        assert 'holds no parameters for node /sma/controller; keys found: /left/controller' \
            in warning
    finally:
        node.destroy_node()


def test_walkthrough_records_on_lockstep_sim_time():
    # issue 16: the wall-clock recording gave 171 s instead of 300 s on a busy machine
    script = (Path(__file__).resolve().parents[1] / 'scripts' / 'walkthrough.sh').read_text()
    assert re.search(r'record_run\(sys.argv\[1\], 300.0, chirp', script)
    assert not re.search(r'^sleep \d\d', script, re.M)     # no wall-clock recording length
