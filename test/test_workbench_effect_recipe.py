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
The recipe for a new effect (docs/architecture.md), shown from outside the package.

A scratch module declares its parameter once (`ParamSpec`), brings its behaviour as an
`Effect` subclass and its physics as an input transform; loaded with the public plug-in
API it is in the catalog with the declared bounds, and it fits.
"""
import textwrap

import pytest
from sma_actuator.core import actuator as act
from sma_actuator.workbench import engine
from sma_actuator.workbench.effects import BUILTIN, CATALOG
from sma_actuator.workbench.plugins import load_plugins
from support import plant_records
from test_workbench_engine import dead_time_record

SCRATCH = '''
import numpy as np
from sma_actuator.core.actuator import ParamSpec
from sma_actuator.workbench.effects import Effect


class RecipeDeadTime(Effect):
    """PWM dead time: the first d0 of every period does not heat the wire."""

    name = 'recipe_dead_time'
    signature = 'small duties heat less than the linear PWM law predicts'
    declares = {'dead_duty': ParamSpec('', 'dead share of the PWM period', neutral=0.0,
                                       fit=(0.0, 0.4, 0.05))}

    def transform_inputs(self, duty_a, duty_b, ambient, values):
        d0 = values['dead_duty']
        return (np.clip((duty_a - d0) / (1 - d0), 0, 1),
                np.clip((duty_b - d0) / (1 - d0), 0, 1), ambient)
'''


@pytest.fixture
def scratch_effect(tmp_path):
    path = tmp_path / 'recipe_dead_time.py'
    path.write_text(textwrap.dedent(SCRATCH))
    added = load_plugins([str(path)])
    try:
        yield CATALOG[added[0]]
    finally:
        CATALOG.pop('recipe_dead_time', None)


@pytest.mark.slow
def test_a_scratch_effect_declared_once_is_in_the_catalog_and_fits(scratch_effect):
    assert scratch_effect.name == 'recipe_dead_time'
    # bounds and start come from the one declaration
    assert scratch_effect.parameters == {'dead_duty': (0.0, 0.4, 0.05)}
    data = dead_time_record(dead_duty=0.2)
    fit = engine.fit_model(data, effects=['recipe_dead_time'])
    base = engine.fit_model(data)
    assert fit.values['dead_duty'] == pytest.approx(0.2, abs=0.03)
    assert fit.validation['nrmse'] < 0.5 * base.validation['nrmse']


def test_every_declared_effect_parameter_reaches_the_plant_and_the_catalog():
    # a parameter declared with an effect needs no further listing anywhere
    pytest.importorskip('rclpy')
    from sma_actuator.nodes.plant_sim import EFFECTS as PLANT_EFFECTS
    declared = {k: s for k, s in act.PARAMETERS.items() if s.effect}
    assert {name for name, *_ in PLANT_EFFECTS} == set(declared)
    for name, lo, hi, description in PLANT_EFFECTS:
        assert (lo, hi) == declared[name].plant and description == declared[name].label
    # the test records of the package's plant stay inside the plant's declared ranges
    for effect, levels in plant_records.EFFECTS.items():
        for changes in levels:
            for k, v in changes.items():
                lo, hi = declared[k].plant
                assert declared[k].effect == effect and lo <= v <= hi, (k, v)
    for effect, names in act.EFFECT_PARAMETERS.items():
        assert set(BUILTIN[effect].parameters) == set(names)
        assert all(CATALOG[effect].parameters[k] == declared[k].fit for k in names)


def test_a_position_parameter_is_named_in_the_rigs_unit():
    # a declared unit of rad means "the rig's position unit": shown as mm on a rig in mm
    assert act.name_in_unit('offset_rad', 'mm') == 'offset_mm'
    assert act.name_in_unit('fatigue_offset_b_rad', '%') == 'fatigue_offset_b_pct'
    # the sensor terms are relative to the half travel h, so they lose the suffix
    assert act.PARAMETERS['sensor_c3_rad'].unit != 'rad'
    assert act.name_in_unit('sensor_c3_rad', 'deg') == 'sensor_c3'
    # a plug-in's undeclared position, and the names a rig in rad keeps
    assert act.name_in_unit('shift_rad', 'mm') == 'shift_mm'
    for unit in ('rad', ''):
        assert act.name_in_unit('offset_rad', unit) == 'offset_rad'
    assert act.name_in_unit('delay_s', 'mm') == 'delay_s'
