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
Whether the training records identify the thermal time constant (`identifiability`).

One heating history (a step) is fitted equally well at any τ; a second duty level ties τ.
Simulated single-wire records of the package's plant, and the measured `step_a` through
`sma-model fit`.
"""
import json
from pathlib import Path

from conftest import real_data_path
import numpy as np
import pytest
from sma_actuator.core.actuator import ActuatorParams, simulate
from sma_actuator.core.datakinds import DynamicData
from sma_actuator.workbench import cli
from sma_actuator.workbench.engine import fit_model
from sma_actuator.workbench.identifiability import MIN_PROFILE_RISE, tau_profile
from sma_actuator.workbench.records import join
import yaml

WIRE = Path(real_data_path()).parent / 'spring_biased_wire'
DT = 0.05


def single_wire(levels, seconds_each=20.0, seed=0):
    """Return a simulated wire against a spring [mm]: 2 s at rest, then each duty held."""
    n_each = int(round(seconds_each / DT))
    duty = np.concatenate([np.zeros(int(2.0 / DT))] + [np.full(n_each, u) for u in levels])
    tr = simulate(ActuatorParams(), duty, np.zeros(duty.size), DT)
    noise = np.random.default_rng(seed).normal(0.0, 0.01, duty.size)
    y = 8.0 * (tr.position_rad - tr.position_rad[0]) + noise
    return DynamicData(np.arange(duty.size) * DT, duty, np.zeros(duty.size), y,
                       position_unit='mm', layout='single')


def all_training(*records):
    """Return the records joined at rest, every sample training."""
    data = join([(f'r{i}', d) for i, d in enumerate(records)])
    return DynamicData(data.time, data.duty_a, data.duty_b, data.position, data.ambient,
                       data.setpoint, data.position_unit, data.layout, data.segments,
                       data.scored, len(data))


def test_one_step_fits_any_time_constant_and_two_levels_tie_it():
    step = all_training(single_wire([0.35]))
    profile = tau_profile(step, fit_model(step))
    assert not profile.identified
    assert max(profile.train_nrmse) < (1.0 + MIN_PROFILE_RISE) * profile.fitted_nrmse
    assert 'do not identify the thermal time constant' in profile.note()
    # two duty levels: a step up, then further up and back down to a middle level
    levels = all_training(single_wire([0.35]), single_wire([0.2, 0.5, 0.25], seed=1))
    profile = tau_profile(levels, fit_model(levels))
    assert profile.identified and profile.note() == ''
    assert min(profile.train_nrmse) > 2.0 * profile.fitted_nrmse


def test_a_pinned_time_constant_stays_where_it_is_held():
    data = all_training(single_wire([0.2, 0.5, 0.25]))
    fit = fit_model(data, pinned={'tau_s': 1.7})
    assert fit.values['tau_s'] == pytest.approx(1.7, rel=1e-5)
    assert fit_model(data).values['tau_s'] == pytest.approx(ActuatorParams().tau_s, rel=0.1)


@pytest.mark.skipif(not (WIRE / 'step_a.csv').is_file(), reason='shared data not found')
def test_fit_says_when_the_measured_step_leaves_the_time_constant_open(tmp_path, capsys):
    out = tmp_path / 'step.yaml'
    code = cli.main(['fit', str(WIRE / 'step_a.csv'), '--out', str(out), '--json'])
    text, err = capsys.readouterr()
    assert code == 0, err
    profile = json.loads(text)['tau_profile']
    assert profile['identified'] is False
    assert profile['tau_s'] == pytest.approx([0.5 * profile['fitted_tau_s'],
                                              2.0 * profile['fitted_tau_s']])
    assert 'note: the training records do not identify the thermal time constant' in err
    assert yaml.safe_load(out.read_text())['tau_profile'] == profile


@pytest.mark.slow
@pytest.mark.skipif(not (WIRE / 'ramp_a.csv').is_file(), reason='shared data not found')
def test_diagnose_blames_the_open_time_constant_not_a_missing_effect(capsys):
    """Trained on step_a alone, ramp_a held out: 14 % held out, and no effect named for it."""
    args = ['diagnose', str(WIRE / 'step_a.csv'), str(WIRE / 'ramp_a.csv'), '--candidates',
            'delay', 'fast_dynamics', '--max-rate', '25', '--jobs', '1']
    code = cli.main(args + ['--json'])
    text, err = capsys.readouterr()
    assert code == 0, err
    doc = json.loads(text)
    assert doc['missing_effect'] is None and doc['baseline']['validation_nrmse'] > 0.05
    assert doc['baseline']['tau_profile']['identified'] is False
    code = cli.main(args)
    text, err = capsys.readouterr()
    assert code == 0, err
    assert 'a held-out error from a wrong τ is not a missing effect' in text
