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

"""The two data kinds answer the same questions (sma_actuator.core.datakinds)."""
import numpy as np
import pytest
from sma_actuator.core.datakinds import DynamicData, Split, StaticData
from sma_actuator.workbench.effects import get_effect


def _dynamic(n=100, **kw):
    t = np.arange(n) * 0.1
    return DynamicData(t, 0.5 + 0.4 * np.sin(t), np.zeros(n), np.sin(t), **kw)


def _static():
    curve = np.repeat(np.arange(4), 5)
    u = np.tile(np.linspace(0.0, 1.0, 5), 4)
    return StaticData(u, u ** 2 + curve, curve)


def test_default_splits_are_the_time_split_and_the_odd_curves():
    d = _dynamic()
    assert d.default_split() == Split(70)
    assert _dynamic(split=40).default_split() == Split(40)   # held-out records start there
    s = _static()
    assert s.default_split() == Split(curves=(1, 3))
    np.testing.assert_array_equal(s.held_out(), np.isin(s.curve, [1, 3]))


def test_split_masks_skip_the_burn_in_and_the_rest_gaps():
    scored = np.ones(100, bool)
    scored[50:55] = False
    d = _dynamic(scored=scored)
    train, val = d.split_masks(Split(60, burn_in=10))
    assert np.flatnonzero(train).tolist() == list(range(10, 50)) + list(range(55, 60))
    assert np.flatnonzero(val).tolist() == list(range(60, 100))
    assert d.span() == pytest.approx(np.ptp(d.position[scored]))


def test_a_static_prediction_per_curve_is_laid_out_like_the_output():
    s = _static()
    per_curve = [(c, s.output[s.curve == c]) for c in (3, 2, 1, 0)]
    np.testing.assert_array_equal(s.flat(per_curve), s.output)
    with pytest.raises(ValueError, match='misses some curves'):
        s.flat(per_curve[:3])
    with pytest.raises(ValueError, match='prediction for curve 3 has 4 points'):
        s.flat([(3, np.zeros(4))])


def test_each_kind_says_which_effects_it_cannot_fit():
    assert _static().unsupported(get_effect('delay')) == 'needs dynamic (time-series) data'
    assert _static().unsupported(get_effect('saturation')) is None
    single = _dynamic(layout='single')
    assert 'two wires' in single.unsupported(get_effect('asymmetric_wires'))
    assert _dynamic().unsupported(get_effect('asymmetric_wires')) is None


def test_both_kinds_name_their_report_figures_and_axis():
    for data in (_dynamic(), _static()):
        assert data.kind in ('dynamic', 'static')
        assert 'residual.png' in dict(data.figures)
        assert data.axis_label


def test_the_rig_and_the_scored_split_are_the_records_and_empty_for_curves():
    assert _dynamic(position_unit='mm', layout='single').rig() == {'position_unit': 'mm',
                                                                   'layout': 'single'}
    assert _static().rig() == {}
    scored = np.ones(100, bool)
    scored[50:55] = False
    # 5 gap samples before the split's start drop out; the burn-in is not carried over
    assert _dynamic(scored=scored).scored_split(Split(60, burn_in=10)) == Split(55)
    assert _dynamic().scored_split(Split(60)) == Split(60)
    assert _dynamic(scored=scored).scored_split(None) is None
    assert _static().scored_split(Split(curves=(1,))) == Split(curves=(1,))


def test_both_kinds_say_what_they_are_in_a_table_row_and_a_sentence():
    row = _dynamic().columns()
    assert row == {'samples': 100, 'duration_s': pytest.approx(9.9), 'rate_hz': pytest.approx(10),
                   'layout': 'antagonistic', 'position_unit': 'rad'}
    assert _static().columns() == {'samples': 20, 'duration_s': None, 'rate_hz': None,
                                   'layout': 'static curves', 'position_unit': None}
    assert (_dynamic().noun, _static().noun) == ('a dynamic record', 'static curves')
    assert _dynamic().joinable and not _static().joinable
