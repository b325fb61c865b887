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
The rooms of sma_actuator and what may import what (docs/architecture.md), from the source.

Every module's imports are parsed (function-local ones included) and resolved to absolute
names; no module is imported, so this runs without ROS.
"""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / 'sma_actuator'

# room -> the rooms it may import (docs/architecture.md, "What may import what")
ALLOWED = {
    'core': set(),
    'bag': set(),
    'control': {'core'},
    'workbench': {'core', 'bag'},
    'hardware': {'core', 'control'},
    'profiles': {'core'},
    'figures': {'core'},
    'nodes': {'core', 'control', 'hardware', 'bag', 'profiles'},
    'in_process': {'nodes'},
    'demo': {'nodes', 'in_process', 'control'},
    'launching': set(),
}
ROS_FREE = ('core', 'control', 'hardware', 'bag', 'workbench', 'profiles', 'figures')
ROS_MODULES = {'rclpy', 'launch', 'launch_ros', 'ament_index_python', 'rcl_interfaces',
               'builtin_interfaces', 'rosidl_runtime_py', 'rosbag2_py'}


def _room(path):
    """Return the room of a module: its sub-package, or its name at the top level."""
    rel = path.relative_to(PACKAGE)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def _imports(path):
    """Return the absolute names of the modules `path` imports (names for `from . import`)."""
    package = ['sma_actuator', *path.relative_to(PACKAGE).parts[:-1]]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out.extend(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            out.append(node.module)
        elif isinstance(node, ast.ImportFrom):
            base = '.'.join(package[:len(package) - node.level + 1])
            if node.module:
                out.append(f'{base}.{node.module}')
            else:
                out.extend(f'{base}.{alias.name}' for alias in node.names)
    return out


def _is_ros(name):
    top = name.split('.')[0]
    return top in ROS_MODULES or top.endswith(('_msgs', '_interfaces'))


def _graph():
    """Return {(room, module path): [imported module names]} of every package module."""
    return {(_room(p), p): _imports(p) for p in sorted(PACKAGE.rglob('*.py'))
            if p.parent != PACKAGE or p.stem != '__init__'}


def _target_room(name):
    parts = name.split('.')
    return parts[1] if parts[0] == 'sma_actuator' and len(parts) > 1 else None


def test_every_room_is_in_the_table():
    rooms = {room for room, _ in _graph()}
    assert rooms == set(ALLOWED), 'a new room: add it to docs/architecture.md and ALLOWED'


def test_rooms_import_only_what_the_architecture_allows():
    wrong = []
    for (room, path), names in _graph().items():
        for name in names:
            target = _target_room(name)
            if target and target != room and target != '__version__' \
                    and target not in ALLOWED[room]:
                wrong.append(f'{path.relative_to(PACKAGE)} imports {name}')
    assert not wrong, wrong


@pytest.mark.parametrize('room', ROS_FREE)
def test_ros_free_rooms_import_no_ros_and_no_nodes(room):
    found = [f'{path.relative_to(PACKAGE)} imports {name}'
             for (r, path), names in _graph().items() if r == room
             for name in names if _is_ros(name) or _target_room(name) == 'nodes']
    assert not found, found


def test_only_entry_points_import_the_nodes():
    importers = {room for (room, _), names in _graph().items()
                 if any(_target_room(n) == 'nodes' for n in names)}
    assert importers <= {'nodes', 'in_process', 'demo'}


def test_the_import_parser_sees_relative_and_local_imports():
    # the checks above are only as good as the parser: a relative import of a sibling
    # room and an import inside a function must both count
    graph = _graph()
    plant = next(names for (room, p), names in graph.items() if p.name == 'plant_sim.py')
    assert 'sma_actuator.core.actuator' in plant and 'rclpy' in plant
    demo = next(names for (room, p), names in graph.items() if p.name == 'demo.py')
    assert 'sma_actuator.in_process' in demo
