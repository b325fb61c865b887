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
Replay into plant_sim reproduces the recorded run (benchmarks/bench_replay_plant.py).

The recorded closed loop is replayed (duty only) into a fresh plant_sim that owns the time
in lockstep with replay (follow_clock); the simulated shaft must follow the recorded one.
The benchmark does 10 runs on a loaded machine with tight tolerances; here one run with
generous ones. Also: replay refuses to play into nothing.
"""
import importlib.util
from pathlib import Path
import subprocess

import pytest

# slow: a recorded run replayed into a lockstep plant (quick run: -m "not slow")
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]


def _bench():
    spec = importlib.util.spec_from_file_location(
        'bench_replay_plant', ROOT / 'benchmarks' / 'bench_replay_plant.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_replayed_duty_drives_a_fresh_plant_along_the_recorded_path(tmp_path, ros_domain_id):
    bench = _bench()
    bag = bench.record_reference(tmp_path / 'reference', duration_s=10.0)
    reference = bench.joint_states(bag)
    rms, worst, _ = bench.compare(reference, bench.replay_once(bag, ros_domain_id))
    assert rms < 0.02 and worst < 0.08, (rms, worst)
    # the run moved: a shaft left at rest would also be "close" to a flat recording
    assert reference[1].max() > 0.2 and reference[1].min() < -0.2


def test_replay_without_its_duty_subscriber_does_not_play(tmp_path, ros_domain_id):
    from sma_actuator.bag.synthetic import cdr_encoder
    from sma_actuator.bag.writer import BagWriter
    bag = tmp_path / 'bag'
    with BagWriter(bag) as writer:
        writer.add_topic('/sma/duty', 'std_msgs/msg/Float64MultiArray')
        for k in range(5):
            writer.write('/sma/duty', cdr_encoder('std_msgs/msg/Float64MultiArray')(
                {'data': [0.5, 0.0]}), 1_000_000_000 + k * 10_000_000)
    result = subprocess.run(
        _bench()._console('replay') + ['--ros-args', '-p', f'bag_path:={bag}',
                                       '-p', 'wait_for_subscribers_s:=1.0'],
        capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert "no subscriber on ['/sma/duty']" in result.stderr


@pytest.mark.parametrize('bad', ['clock:=true', 'rate:=2.0'])
def test_follow_clock_excludes_its_own_timing(tmp_path, bad):
    from sma_actuator.bag.synthetic import cdr_encoder
    from sma_actuator.bag.writer import BagWriter
    bag = tmp_path / 'bag'
    with BagWriter(bag) as writer:
        writer.add_topic('/sma/duty', 'std_msgs/msg/Float64MultiArray')
        writer.write('/sma/duty', cdr_encoder('std_msgs/msg/Float64MultiArray')(
            {'data': [0.0, 0.0]}), 1_000_000_000)
    result = subprocess.run(
        _bench()._console('replay') + ['--ros-args', '-p', f'bag_path:={bag}',
                                       '-p', 'follow_clock:=true', '-p', bad],
        capture_output=True, text=True, timeout=120)
    assert result.returncode == 1 and 'follow_clock' in result.stderr
    assert 'Traceback' not in result.stderr
