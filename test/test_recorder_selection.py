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

"""Recorder logic (ROS-free): topic selection and bag naming."""
from datetime import datetime
from pathlib import Path

import pytest
from sma_actuator.bag.recording import bag_directory, DEFAULT_TOPICS, TopicSelector


def test_default_selection_is_the_sma_namespace_and_diagnostics():
    selector = TopicSelector(DEFAULT_TOPICS, '/sma')
    for topic in ('/sma/duty', '/sma/joint_states', '/sma/wire_a/temperature', '/diagnostics',
                  '/sma/sub/topic'):
        assert selector.matches(topic), topic
    for topic in ('/rosout', '/parameter_events', '/clock', '/measured/joint_states',
                  '/diagnostics_agg', '/smart', '/left/duty'):
        assert not selector.matches(topic), topic


def test_relative_patterns_resolve_in_the_recorder_namespace():
    selector = TopicSelector(DEFAULT_TOPICS, '/left')
    assert selector.matches('/left/duty') and selector.matches('/left/wire_b/temperature')
    assert not selector.matches('/sma/duty') and not selector.matches('/right/duty')
    assert TopicSelector(['duty'], '/').patterns == ['/duty']


def test_exact_names_and_patterns_mix():
    selector = TopicSelector(['/sma/duty', '/measured/*', ''])
    assert selector.matches('/sma/duty') and selector.matches('/measured/joint_states')
    assert not selector.matches('/sma/setpoint')


@pytest.mark.parametrize('patterns, problem', [([], 'no topics'), (['', ' '], 'no topics'),
                                               (['~/duty'], 'private')])
def test_bad_selections_are_rejected(patterns, problem):
    with pytest.raises(ValueError, match=problem):
        TopicSelector(patterns)


def test_bag_name_comes_from_template_with_date_and_run_name():
    when = datetime(2025, 3, 4, 5, 6, 7)
    assert bag_directory('runs', 'step1', now=when) == Path('runs/step1_2025_03_04-05_06_07')
    assert bag_directory('/data', 'x', '{date:%Y%m%d}-{run_name}', when) == Path(
        '/data/20250304-x')


@pytest.mark.parametrize('run_name, template, problem', [
    ('../../etc', '{run_name}', 'may only hold'),
    ('a b', '{run_name}', 'may only hold'),
    ('ok', '{run}', 'bad bag name template'),
    ('', '{run_name}', 'may only hold'),
])
def test_bad_names_are_rejected(run_name, template, problem):
    with pytest.raises(ValueError, match=problem):
        bag_directory('runs', run_name, template)
