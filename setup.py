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
ament_python package definition for sma_actuator.

The same file serves `colcon build` on a Jazzy install (console scripts land in
lib/sma_actuator so `ros2 run sma_actuator <node>` finds them) and `pip install`
into a venv with the Jazzy wheels (console scripts land on PATH).
"""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'sma_actuator'

# ros2 run names (underscored, like ros2/demos) -> entry point
NODES = {
    'plant_sim': 'sma_actuator.nodes.plant_sim:main',
    'controller': 'sma_actuator.nodes.controller:main',
    'setpoint': 'sma_actuator.nodes.setpoint:main',
    'hardware_bridge': 'sma_actuator.nodes.hardware_bridge:main',
    'recorder': 'sma_actuator.nodes.recorder:main',
    'replay': 'sma_actuator.nodes.replay:main',
    'mcu_emulator': 'sma_actuator.hardware.emulator:main',
    'closed_loop_demo': 'sma_actuator.demo:main',
    'model_figures': 'sma_actuator.figures:main',
    'sma-model': 'sma_actuator.workbench.cli:main',
}

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml')),
        ('share/' + PACKAGE + '/launch', glob('launch/*.launch.py')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='sma_actuator developers',
    maintainer_email='dev@sma-actuator.invalid',
    description='Antagonistic SMA wire actuator: model core, ROS 2 nodes, bridge, MCAP, workbench',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [f'{name} = {target}' for name, target in NODES.items()],
    },
)
