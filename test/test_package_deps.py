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
package.xml declares every runtime import of the package by its rosdep key.

The package's modules and launch files are walked with ast; each top-level module that is
neither the standard library nor sma_actuator must map to a rosdep key in ROSDEP_KEYS and
that key must be an exec_depend. A new import without a declaration fails here.
"""
import ast
from pathlib import Path
import sys
import xml.etree.ElementTree as ET

ROOT = Path(__file__).resolve().parents[1]

# top-level import -> rosdep key (ROS packages are their own keys). Keys as in
# ros/rosdistro rosdep/{base,python}.yaml; the pip-only libraries follow its
# "python3-<name>-pip" convention.
ROSDEP_KEYS = {
    'ament_index_python': 'ament_index_python',
    'builtin_interfaces': 'builtin_interfaces',
    'dask': 'python3-dask',
    'diagnostic_msgs': 'diagnostic_msgs',
    'distributed': 'python3-distributed',
    'launch': 'launch',
    'launch_ros': 'launch_ros',
    'lz4': 'python3-lz4',
    'matplotlib': 'python3-matplotlib',
    'mcap': 'python3-mcap-pip',
    'mcap_ros2': 'python3-mcap-ros2-support-pip',
    'numba': 'python3-numba',
    'numpy': 'python3-numpy',
    'pyarrow': 'python3-pyarrow',
    'rcl_interfaces': 'rcl_interfaces',
    'rclpy': 'rclpy',
    'rosgraph_msgs': 'rosgraph_msgs',
    'scipy': 'python3-scipy',
    'sensor_msgs': 'sensor_msgs',
    'serial': 'python3-serial',
    'std_msgs': 'std_msgs',
    'yaml': 'python3-yaml',
    'zstandard': 'python3-zstandard',
}
# what the ament_python template (ros2 pkg create) declares for its tests
TEMPLATE_TEST_DEPENDS = {'ament_copyright', 'ament_flake8', 'ament_pep257', 'python3-pytest'}


def _sources():
    yield from sorted((ROOT / 'sma_actuator').rglob('*.py'))
    yield from sorted((ROOT / 'launch').glob('*.py'))


def third_party_imports(paths):
    """Return {top-level module: [files importing it]} outside the stdlib and the package."""
    found = {}
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split('.')[0]
                if top not in sys.stdlib_module_names and top != 'sma_actuator':
                    found.setdefault(top, []).append(path.name)
    return found


def _declared(tag):
    return {e.text.strip() for e in ET.parse(ROOT / 'package.xml').getroot().iter(tag)}


def test_every_runtime_import_is_declared_by_its_rosdep_key():
    imports = third_party_imports(_sources())
    unmapped = {m: files for m, files in imports.items() if m not in ROSDEP_KEYS}
    assert not unmapped, f'imports without a rosdep key in ROSDEP_KEYS: {unmapped}'
    runtime = _declared('exec_depend') | _declared('depend')
    missing = {ROSDEP_KEYS[m]: files for m, files in imports.items()
               if ROSDEP_KEYS[m] not in runtime}
    assert not missing, f'package.xml lacks <exec_depend> for {missing}'


def test_every_table_entry_is_declared_in_package_xml():
    runtime = _declared('exec_depend') | _declared('depend')
    assert set(ROSDEP_KEYS.values()) <= runtime, set(ROSDEP_KEYS.values()) - runtime


def test_template_test_depends_are_declared():
    assert TEMPLATE_TEST_DEPENDS <= _declared('test_depend')


def test_the_walk_sees_imports_inside_functions(tmp_path):
    module = tmp_path / 'm.py'
    module.write_text('import os\n\n\ndef f():\n'
                      '    from numba import njit\n    import serial.tools\n')
    assert sorted(third_party_imports([module])) == ['numba', 'serial']
