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

"""Excitation sequences (core.excitation) and model files (core.model_file)."""
import numpy as np
import pytest
from sma_actuator.control.interlock import DeadTimeInterlock, DEFAULT_DEAD_TIME_S
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.core.datakinds import DynamicData
from sma_actuator.core.excitation import (HOLD_TAUS, LEVEL_FRACTIONS, multilevel,
                                          rig_excitation, SWITCH_GAP_S)
from sma_actuator.core.model_file import load_model, save_model
from sma_actuator.workbench.levels import duty_levels
import yaml


def test_multilevel_excites_both_wires_one_at_a_time_with_held_levels():
    levels = (0.3, 0.5, 0.7)
    a, b = multilevel(300.0, 0.025, seed=3, levels=levels, hold_min_s=1.0, hold_max_s=4.0)
    assert len(a) == len(b) == 12000
    assert not ((a > 0) & (b > 0)).any()                       # never both heated
    assert set(np.unique(a)) <= {0.0, *levels} and set(np.unique(b)) <= {0.0, *levels}
    assert (a > 0).mean() > 0.2 and (b > 0).mean() > 0.2      # both wires see real use
    changes = np.flatnonzero(np.diff(a) != 0)
    assert np.diff(changes).min() * 0.025 >= 1.0 - 1e-9       # holds of at least hold_min_s
    # minor loops: some wire-a segments step directly between two non-zero levels
    assert any(a[k] > 0 and a[k + 1] > 0 for k in changes)


def test_multilevel_is_reproducible_per_seed():
    first, again = multilevel(60, 0.025, seed=5)[0], multilevel(60, 0.025, seed=5)[0]
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(multilevel(60, 0.025, seed=5)[0], multilevel(60, 0.025, seed=6)[0])


def test_multilevel_rejects_bad_arguments():
    with pytest.raises(ValueError):
        multilevel(-1, 0.025)
    with pytest.raises(ValueError):
        multilevel(10, 0.025, hold_min_s=3, hold_max_s=2)


def test_model_file_round_trip_keeps_every_parameter(tmp_path):
    p = ActuatorParams(tau_fast_s=np.float64(0.1), gain_ratio_b=1.2)
    path = tmp_path / 'm.yaml'
    save_model(p, path, header='fitted by a test\nsecond line')
    text = path.read_text()
    assert text.startswith('# fitted by a test\n# second line\n')
    back = load_model(path)
    want, got = p.to_dict(), back.to_dict()
    for key in want:
        if key != 'hysteresis':
            assert got[key] == pytest.approx(want[key]), key
    for key in ('r', 'lo', 'hi', 'w'):
        np.testing.assert_allclose(got['hysteresis'][key], want['hysteresis'][key])
    assert yaml.safe_load(text)['model']['tau_fast_s'] == 0.1     # plain float, not numpy


def test_rig_excitation_holds_in_the_wires_time_at_several_duties():
    tau_s, dt = 6.0, 0.025
    a, b = rig_excitation(900.0, dt, tau_s=tau_s, duty_full=0.2, seed=1, switch_gap_s=0.0)
    levels = {round(0.2 * f, 6) for f in LEVEL_FRACTIONS}
    assert not ((a > 0) & (b > 0)).any()                       # never both heated
    assert {round(v, 6) for v in np.unique(np.r_[a, b])} <= levels | {0.0}
    changes = np.flatnonzero((np.diff(a) != 0) | (np.diff(b) != 0))
    assert np.diff(changes).min() * dt >= HOLD_TAUS[0] * tau_s - 1e-9
    assert np.diff(changes).max() * dt <= 2 * HOLD_TAUS[1] * tau_s  # two equal holds at most
    heated = np.r_[a[a > 0], b[b > 0]]
    assert len(np.unique(heated)) == len(levels)
    # the workbench's own test: this record does not heat at one duty level
    data = DynamicData(np.arange(a.size) * dt, a, b, np.zeros(a.size))
    assert not duty_levels(data).one_level


def test_rig_excitation_for_one_wire_heats_wire_a_only():
    pair = rig_excitation(300.0, 0.025, tau_s=2.0, duty_full=0.5, seed=4, switch_gap_s=0.0)
    a, b = rig_excitation(300.0, 0.025, tau_s=2.0, duty_full=0.5, layout='single', seed=4)
    assert not b.any()
    np.testing.assert_array_equal(a, np.maximum(*pair))     # no switch gap on one wire


@pytest.mark.parametrize('jitter_s', [0.0, 0.0125])
def test_the_bridges_interlock_applies_every_command_of_a_rig_excitation(jitter_s):
    # played through the bridge's dead time, a command the interlock holds would be logged
    # as heating that never happened; the switch gap leaves it nothing to hold
    dt = 0.025
    rng = np.random.default_rng(0)

    def held(a, b):
        """Count the commands the interlock holds, each seen within ± jitter_s of its time."""
        interlock = DeadTimeInterlock(DEFAULT_DEAD_TIME_S)
        for k, pair in enumerate(zip(a, b)):
            interlock.apply(*pair, k * dt + rng.uniform(-jitter_s, jitter_s))
        return interlock.held

    plain = rig_excitation(300.0, dt, tau_s=2.0, duty_full=0.5, seed=4, switch_gap_s=0.0)
    a, b = rig_excitation(300.0, dt, tau_s=2.0, duty_full=0.5, seed=4)
    assert held(*plain) > 20 and held(a, b) == 0
    # the gap only zeroes the first samples of each segment that follows the other wire's
    gap = int(np.ceil(SWITCH_GAP_S / dt))
    for now, before, other in ((a, plain[0], plain[1]), (b, plain[1], plain[0])):
        changed = np.flatnonzero(now != before)
        switches = np.flatnonzero((before[1:] > 0) & (other[:-1] > 0)) + 1
        assert switches.size > 5 and not now[changed].any()
        np.testing.assert_array_equal(changed, (switches[:, None] + np.arange(gap)).ravel())


def test_rig_excitation_holds_wire_b_at_its_own_full_stroke_duty():
    a, b = rig_excitation(300.0, 0.025, tau_s=2.0, duty_full=0.5, seed=4)
    a2, b2 = rig_excitation(300.0, 0.025, tau_s=2.0, duty_full=0.5, seed=4, duty_full_b=0.3)
    np.testing.assert_array_equal(a2, a)
    np.testing.assert_allclose(b2, 0.6 * b)
    assert b2.max() == pytest.approx(0.3)


@pytest.mark.parametrize('bad', [{'tau_s': 0.0}, {'tau_s': float('nan')},
                                 {'duty_full': 1.5}, {'duty_full': 0.0},
                                 {'duty_full_b': 1.2}, {'duty_full_b': float('nan')},
                                 {'layout': 'triple'}])
def test_rig_excitation_rejects_bad_arguments(bad):
    args = {'duration_s': 60.0, 'dt': 0.025, 'tau_s': 2.0, 'duty_full': 0.5, **bad}
    with pytest.raises(ValueError):
        rig_excitation(**args)
