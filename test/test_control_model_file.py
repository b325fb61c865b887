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

"""load_model: the one model file (sma-model fit --out), old files converted, clear errors."""
import warnings

import numpy as np
import pytest
from sma_actuator.control import ControllerCore, ControllerSettings, load_model
from sma_actuator.control.closed_loop import CorePlant
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.core.excitation import multilevel
from sma_actuator.core.model_file import ModelFileError, ModelFormatWarning, save_model
from sma_actuator.workbench.cli import main as sma_model
import yaml

DT = 0.025


@pytest.fixture(scope='module')
def fitted_file(tmp_path_factory):
    """Return a model file written by `sma-model fit --out` from a 90 s simulated record."""
    folder = tmp_path_factory.mktemp('fit')
    duty_a, duty_b = multilevel(90.0, DT, seed=4)
    plant = CorePlant(ActuatorParams(), DT, seed=5, dead_time_s=0.0)   # applied = recorded
    pos = [plant.measure()] + [plant.step(a, b) for a, b in zip(duty_a[:-1], duty_b[:-1])]
    csv = folder / 'record.csv'
    np.savetxt(csv, np.column_stack([np.arange(len(duty_a)) * DT, duty_a, duty_b, pos]),
               delimiter=',', header='time,duty_a,duty_b,position', comments='')
    out = folder / 'fitted.yaml'
    assert sma_model(['fit', str(csv), '--out', str(out)]) == 0
    return out


@pytest.mark.slow
def test_load_model_reads_a_sma_model_fit_file_without_warnings(fitted_file):
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        model = load_model(fitted_file)
    assert isinstance(model, ActuatorParams)
    spec = yaml.safe_load(fitted_file.read_text())
    assert model.tau_s == pytest.approx(spec['parameters']['tau_s'])
    assert 1.5 < model.tau_s < 2.5 and model.hysteresis.n_operators > 4
    out = ControllerCore(model, ControllerSettings(mode='pi_inverse')).step(0.3, 0.0, DT, 22.0)
    assert out.duty_a > 0.0 and out.duty_b == 0.0


def test_extra_keys_of_newer_writers_are_accepted(fitted_file, tmp_path):
    spec = yaml.safe_load(fitted_file.read_text())
    spec.update(layout='antagonistic', position_unit='rad', records={'run1': {'offset': 0.01}})
    path = tmp_path / 'newer.yaml'
    path.write_text(yaml.safe_dump(spec))
    assert load_model(path).tau_s == pytest.approx(load_model(fitted_file).tau_s)
    spec['model']['some_future_parameter'] = 1.0
    path.write_text(yaml.safe_dump(spec))
    with pytest.warns(ModelFormatWarning, match='some_future_parameter'):
        load_model(path)


@pytest.mark.parametrize('rig,message', [
    ({'layout': 'single'}, 'fitted on one wire against a bias spring'),
    ({'position_unit': 'mm'}, 'fitted on positions in mm; the controller and the simulated')])
def test_a_fit_of_another_rig_is_refused_for_control(fitted_file, tmp_path, rig, message):
    spec = dict(yaml.safe_load(fitted_file.read_text()), **rig)
    path = tmp_path / 'other_rig.yaml'
    path.write_text(yaml.safe_dump(spec))
    with pytest.raises(ModelFileError, match=message):
        load_model(path)


def test_a_fit_where_wire_a_turns_the_shaft_to_minus_phi_is_refused(fitted_file, tmp_path):
    spec = yaml.safe_load(fitted_file.read_text())
    spec['model']['stroke_rad'] = -spec['model']['stroke_rad']
    path = tmp_path / 'mirrored.yaml'
    path.write_text(yaml.safe_dump(spec))
    with pytest.raises(ModelFileError, match=r'heating wire a lowers the reading .* swap duty_a'):
        load_model(path)


def test_old_actuator_params_files_are_converted_with_a_clear_message(tmp_path):
    path = tmp_path / 'old.yaml'
    path.write_text(yaml.safe_dump(ActuatorParams(tau_fast_s=0.1).to_dict()))
    with pytest.warns(ModelFormatWarning, match='old controller model format'):
        model = load_model(path)
    assert model.tau_fast_s == 0.1


def test_save_model_writes_the_one_format(tmp_path):
    path = save_model(ActuatorParams(delay_s=0.2), tmp_path / 'm.yaml', header='made here',
                      effects=['delay'])
    assert path.read_text().startswith('# made here\n')
    assert yaml.safe_load(path.read_text())['effects'] == ['delay']
    assert load_model(path).delay_s == 0.2


@pytest.mark.parametrize('text, message', [
    (None, 'no such model file'),
    ('effects: [delay]\n', 'no fitted model'),
    ('model: {hysteresis: {r: [1.0], lo: [0.0], hi: [1.0], w: [1.0]}}\n', 'static'),
    ('model: {tau_fast_s: -1.0}\n', 'invalid model: tau_fast_s'),
    ('model: [1, 2\n', 'not valid YAML'),
])
def test_unusable_files_raise_one_line_errors_naming_the_file(tmp_path, text, message):
    path = tmp_path / 'bad.yaml'
    if text is not None:
        path.write_text(text)
    with pytest.raises(ModelFileError, match=message) as err:
        load_model(path)
    assert str(path) in str(err.value) and '\n' not in str(err.value)


def test_the_committed_controller_model_was_made_by_sma_model_fit():
    from sma_actuator.nodes.common import config_path
    path = config_path('controller_model.yaml')
    text = path.read_text()
    assert text.startswith('# Produced by scripts/fit_controller_model.py')
    assert 'sma-model fit' in text.splitlines()[2]
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        model = load_model(path)
    assert 1.5 < model.tau_s < 2.5 and model.hysteresis.n_operators > 4
