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

import pytest

demo = pytest.importorskip('sma_actuator.demo')


def test_demo_writes_the_summary_schema_and_one_figure_per_response(ros_context, tmp_path):
    out = tmp_path / 'run'
    summary = demo.run_all(ros_context, out, profiles=['step'], modes=['pi', 'pi_inverse'],
                           record=False, log=lambda *_: None)
    on_disk = json.loads((out / 'summary.json').read_text())
    assert on_disk == json.loads(json.dumps(summary))
    assert set(on_disk) == {'profiles'}
    assert set(on_disk['profiles']) == {'step'}
    for mode in ('pi', 'pi_inverse'):
        m = on_disk['profiles']['step'][mode]
        assert set(m) == {'rms_error', 'max_error', 'settling_time'}
        assert 0 < m['rms_error'] <= m['max_error']
        assert m['settling_time'] is not None and m['settling_time'] < 8.0   # step settles
        png = out / f'step_{mode}.png'
        assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
        rows = (out / f'step_{mode}.csv').read_text().splitlines()
        assert rows[0].startswith('time_s,setpoint_rad,position_rad')
        assert len(rows) > 15.0 / 0.025 * 0.95          # 40 Hz over the 15 s run


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
