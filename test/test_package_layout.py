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
The ament_python layout, checked mechanically.

A colcon build of this package installs every console script where `ros2 run sma_actuator
<node>` looks, plus package.xml, the ament index marker, the config YAML files and the launch
files; `colcon test` runs the package's pytest suite.
"""
import ast
import configparser
from pathlib import Path
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

# slow: colcon build and colcon test of the package (quick run: -m "not slow")
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]


def _console_scripts():
    tree = ast.parse((ROOT / 'setup.py').read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and getattr(node.targets[0], 'id', '') == 'NODES':
            return sorted(ast.literal_eval(node.value))
    raise AssertionError('setup.py has no NODES table')


def test_package_xml_is_format3_ament_python_with_exec_depends():
    root = ET.parse(ROOT / 'package.xml').getroot()
    assert root.get('format') == '3'
    assert root.findtext('name') == 'sma_actuator'
    assert root.find('export/build_type').text == 'ament_python'
    deps = {e.text for e in root.findall('exec_depend')}
    assert {'rclpy', 'std_msgs', 'sensor_msgs', 'diagnostic_msgs'} <= deps


def test_setup_cfg_puts_scripts_where_ros2_run_looks():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / 'setup.cfg')
    assert cfg['develop']['script_dir'] == '$base/lib/sma_actuator'
    assert cfg['install']['install_scripts'] == '$base/lib/sma_actuator'
    assert (ROOT / 'resource' / 'sma_actuator').is_file()


def test_every_entry_point_imports_a_main():
    import importlib
    setup_src = (ROOT / 'setup.py').read_text()
    tree = ast.parse(setup_src)
    table = next(ast.literal_eval(n.value) for n in ast.walk(tree)
                 if isinstance(n, ast.Assign) and getattr(n.targets[0], 'id', '') == 'NODES')
    for name, target in table.items():
        module, func = target.split(':')
        assert callable(getattr(importlib.import_module(module), func)), name


@pytest.mark.skipif(shutil.which('colcon') is None
                    and not (Path(sys.prefix) / 'bin' / 'colcon').exists(),
                    reason='colcon not installed (pip install colcon-core colcon-ros)')
def test_colcon_build_installs_ros2_run_layout(tmp_path):
    colcon = shutil.which('colcon') or str(Path(sys.prefix) / 'bin' / 'colcon')
    # build from a copy so the build never writes into the source tree
    src = tmp_path / 'src' / 'sma_actuator'
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(
        '.git', '.venv', 'runs', 'build', 'install', 'log', '*.egg-info', '__pycache__'))
    result = subprocess.run(
        [colcon, '--log-base', str(tmp_path / 'log'), 'build',
         '--base-paths', str(tmp_path / 'src'), '--build-base', str(tmp_path / 'build'),
         '--install-base', str(tmp_path / 'install')],
        cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    prefix = tmp_path / 'install' / 'sma_actuator'
    installed = sorted(p.name for p in (prefix / 'lib' / 'sma_actuator').iterdir())
    assert installed == _console_scripts()
    assert (prefix / 'share' / 'sma_actuator' / 'package.xml').is_file()
    index = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages'
    assert (index / 'sma_actuator').is_file()
    configs = {p.name for p in (ROOT / 'config').glob('*.yaml')}
    installed = {p.name for p in (prefix / 'share' / 'sma_actuator' / 'config').iterdir()}
    assert configs and configs <= installed
    launches = {p.name for p in (ROOT / 'launch').glob('*.launch.py')}
    assert launches == {'sim.launch.py', 'hardware.launch.py', 'emulator.launch.py'}
    assert launches == {p.name for p in (prefix / 'share' / 'sma_actuator' / 'launch').iterdir()}

    # `colcon test` runs the package's pytest suite (ament_python): one fast test here
    base = [colcon, '--log-base', str(tmp_path / 'log')]
    dirs = ['--build-base', str(tmp_path / 'build'), '--install-base', str(tmp_path / 'install')]
    result = subprocess.run(
        base + ['test', '--base-paths', str(tmp_path / 'src'), *dirs, '--pytest-args', '-k',
                'test_template_test_depends_are_declared'],
        cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    result = subprocess.run(base + ['test-result', '--test-result-base', str(tmp_path / 'build'),
                                    '--verbose'],
                            cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout[-2000:]
    assert '1 test, 0 errors, 0 failures, 0 skipped' in result.stdout, result.stdout[-2000:]
