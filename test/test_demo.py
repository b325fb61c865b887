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

"""closed_loop_demo: summary.json schema, figures and traces from a real (short) run."""
import json
import subprocess
import sys

import pytest

demo = pytest.importorskip('sma_actuator.demo')


@pytest.mark.slow
def test_demo_writes_the_summary_schema_and_one_figure_per_response(ros_context, tmp_path):
    out = tmp_path / 'run'
    summary = demo.run_all(ros_context, out, profiles=['step'], modes=['pi', 'pi_inverse'],
                           record=False, log=lambda *_: None)
    on_disk = json.loads((out / 'summary.json').read_text())
    assert on_disk == json.loads(json.dumps(summary))
    assert set(on_disk) == {'profiles'}
    assert set(on_disk['profiles']) == {'step'}
    # one figure per profile, both modes overlaid
    assert (out / 'step.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert not list(out.glob('step_*.png'))
    for mode in ('pi', 'pi_inverse'):
        m = on_disk['profiles']['step'][mode]
        assert set(m) == {'rms_error_rad', 'max_error_rad', 'rise_time_s', 'overshoot_pct',
                          'steady_state_error_rad', 'settling_time_s'}
        assert 0 < m['rms_error_rad'] <= m['max_error_rad']
        assert m['settling_time_s'] is not None and m['settling_time_s'] < 8.0   # step settles
        assert 0 < m['rise_time_s'] < m['settling_time_s']
        assert m['overshoot_pct'] >= 0 and abs(m['steady_state_error_rad']) < 0.025
        rows = (out / f'step_{mode}.csv').read_text().splitlines()
        assert rows[0].startswith('time_s,setpoint_rad,position_rad')
        assert len(rows) > 15.0 / 0.025 * 0.95          # 40 Hz over the 15 s run


@pytest.mark.slow
def test_recorder_hook_records_each_run_to_mcap(ros_context, tmp_path):
    if demo.recorder_factory(tmp_path / 'probe') is None:
        pytest.skip('sma_actuator.nodes.recorder not available')
    from mcap.reader import make_reader
    out = tmp_path / 'run'
    demo.run_all(ros_context, out, profiles=['step'], modes=['pi'], record=True,
                 log=lambda *_: None)
    files = sorted((out / 'bags' / 'step_pi').glob('*.mcap'))
    assert files
    with open(files[0], 'rb') as f:
        topics = [channel.topic for _, channel, _ in make_reader(f).iter_messages()]
    assert topics.count('/sma/joint_states') > 100        # most of the 15 s at 40 Hz
    assert '/sma/duty' in topics and '/sma/setpoint' in topics
    # the bag is logged on the plant's sim time: it spans the simulated run, not the
    # (much shorter) wall time of the accelerated loop, so load_run sees the real run
    from sma_actuator.bag.arrays import load_run
    run = load_run(out / 'bags' / 'step_pi')
    span = run['time'][-1] - run['time'][0]
    assert 14.0 < span < 16.0, span


@pytest.mark.slow
def test_sine_metrics_give_phase_lag_and_no_settling_time(ros_context, tmp_path):
    summary = demo.run_all(ros_context, tmp_path / 'run', profiles=['sine'], modes=['pi'],
                           record=False, log=lambda *_: None)
    m = summary['profiles']['sine']['pi']
    assert set(m) == {'rms_error_rad', 'max_error_rad', 'phase_lag_s', 'phase_lag_deg', 'gain'}
    assert 0 < m['phase_lag_s'] < 5.0      # the shaft trails a 20 s sine by a fraction of it
    assert m['phase_lag_deg'] == pytest.approx(m['phase_lag_s'] / 20.0 * 360.0)


def test_an_existing_name_is_refused_without_force(tmp_path):
    (tmp_path / 'runs' / 'taken').mkdir(parents=True)
    (tmp_path / 'runs' / 'taken' / 'summary.json').write_text('{"precious": 1}')
    result = subprocess.run([sys.executable, '-m', 'sma_actuator.demo', '--name', 'taken',
                             '--out-dir', str(tmp_path / 'runs'), '--profiles', 'step'],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f'closed_loop_demo: {tmp_path / "runs" / "taken"} already exists; choose another '
        '--name or use --force to replace it']
    assert (tmp_path / 'runs' / 'taken' / 'summary.json').read_text() == '{"precious": 1}'


@pytest.mark.slow
def test_record_run_is_the_same_bag_on_every_run(tmp_path):
    # the walkthrough's recording: one executor on lockstep sim time, any host load
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    from sma_actuator.bag.reader import BagReader
    chirp = {'profile': 'chirp', 'amplitude': 0.6, 'chirp_end_hz': 0.3, 'delay_s': 0.5}
    runs = []
    for k in range(2):
        demo.record_run(tmp_path / f'bag{k}', 4.0, chirp, plant={'delay_s': 0.3})
        samples = {}
        for m in BagReader(tmp_path / f'bag{k}').messages(['/sma/joint_states']):
            js = deserialize_message(m.data, JointState)
            stamp = (js.header.stamp.sec, js.header.stamp.nanosec)
            if stamp <= (4, 0):     # the run stops at 4 s; a sample in flight may follow
                samples[stamp] = js.position[0]
        runs.append(samples)
    assert runs[0] == runs[1]
    assert len(runs[0]) == 160                              # 4 s of sim time at 40 Hz
    assert max(runs[0].values()) > 0.1                      # the chirp moved the shaft
