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
Error breakdown by regime, residual correlation tests and the HTML report.

Predictions are made by hand (measured minus a known error), so each test knows where the
error is and checks that the breakdown and the tests find it there.
"""
import re

import numpy as np
import pytest
from sma_actuator.core.identification import DynamicData
from sma_actuator.core.scoring import scores
from sma_actuator.workbench.compare import (compare, cross_correlation, loop_masks,
                                            residual_tests, reversals)
from sma_actuator.workbench.diagnosis import Diagnosis
from sma_actuator.workbench.engine import fit_model, part_scores
from sma_actuator.workbench.records import join
from sma_actuator.workbench.report import (plot_time, ReportError, write_diagnosis_report,
                                           write_report)

DT = 0.05


def _record(n=1200, seed=0):
    """Slow triangle sweeps of duty a vs b; position follows the duty difference."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    tri = 2 * np.abs((t / 20.0) % 1 - 0.5)          # 0..1, period 20 s
    da, db = 0.6 * tri, 0.6 * (1 - tri)
    pos = 0.8 * (tri - 0.5) + 0.002 * rng.standard_normal(n)
    return DynamicData(t, da, db, pos, ambient=22 + 0.001 * t)


def _rows(result, group):
    return {r['label']: r for r in result.regimes[group]}


def test_scores_use_a_70_30_time_split_by_default():
    data = _record()
    pred = data.position + 0.01 * np.sin(data.time)
    res = compare(data, pred)
    k = int(round(0.7 * len(data)))
    span = np.ptp(data.position)   # every part is normalised by the whole record's range
    for part, rows in (('train', slice(None, k)), ('validation', slice(k, None))):
        expected = scores(data.position[rows], pred[rows], span)
        assert {key: res.scores[part][key] for key in expected} == pytest.approx(expected)
        # how much of the whole range the part covers (under 20 %: uninformative)
        assert res.scores[part]['coverage'] == pytest.approx(np.ptp(data.position[rows]) / span)
    assert res.train_mask.sum() == k


def test_error_at_the_high_end_of_travel_is_found_there():
    data = _record()
    y = data.position
    high = y >= y.max() - 0.1 * np.ptp(y)
    res = compare(data, y - 0.05 * high)
    rows = _rows(res, 'travel')
    assert rows['high end']['error_share'] == pytest.approx(1.0)
    assert rows['middle']['rmse'] == pytest.approx(0.0, abs=1e-12)
    assert rows['high end']['bias'] == pytest.approx(0.05)
    assert (res.concentrated[0]['group'], res.concentrated[0]['label']) == ('travel', 'high end')


def test_heating_regime_follows_the_model_temperatures():
    data = _record()
    # model temperatures: wire a heats while duty a rises, wire b the other half
    theta_a = 22 + 100 * np.cumsum(np.gradient(data.duty_a))
    theta_b = 22 + 100 * np.cumsum(np.gradient(data.duty_b))
    heating_b = np.gradient(theta_b, DT) > 0.1
    res = compare(data, data.position - 0.03 * heating_b,
                  signals={'theta_a': theta_a, 'theta_b': theta_b})
    rows = _rows(res, 'thermal')
    assert rows['heating wire b']['error_share'] == pytest.approx(1.0)
    assert rows['heating wire a']['rmse'] == pytest.approx(0.0, abs=1e-12)
    assert 0.4 < rows['heating wire b']['fraction'] < 0.6


def test_duty_proxy_stands_in_without_model_temperatures():
    data = _record()
    res = compare(data, data.position)
    assert 'theta_a (proxy)' in res.correlations['untested'] + list(res.correlations['cross'])
    labels = _rows(res, 'thermal')
    assert labels['heating wire a']['samples'] > 0 and labels['heating wire b']['samples'] > 0


def test_time_quartiles_and_rising_falling():
    data = _record()
    n = len(data)
    late = np.arange(n) >= 3 * n // 4
    res = compare(data, data.position - 0.02 * late)
    assert _rows(res, 'time')['Q4']['error_share'] == pytest.approx(1.0)
    rising = np.gradient(data.position) > 0
    res = compare(data, data.position - 0.02 * rising)
    d = _rows(res, 'direction')
    assert d['rising']['rmse'] > 5 * (d['falling']['rmse'] or 0.0) + 0.01


def test_major_and_minor_loops_from_reversals():
    up = np.linspace(0, 1, 101)
    y = np.concatenate([up, up[::-1], 0.2 * up[1:], 0.2 * up[::-1], up[1:]])  # big, small, big
    turns = reversals(y, 0.05)
    assert turns == [100, 201, 301, 402]
    masks = loop_masks(y, 1.0)
    assert masks['major'][:201].all() and masks['minor'][230:380].all()
    assert masks['major'][402:].all()


def test_cross_correlation_lag_sign_input_leading_is_positive():
    rng = np.random.default_rng(1)
    u = rng.standard_normal(2000)
    e = np.roll(u, 7)                      # e(t) = u(t − 7)
    r = cross_correlation(e, u, 20)
    assert np.argmax(r) - 20 == 7 and r.max() == pytest.approx(1.0, abs=0.05)
    assert np.max(np.abs(np.delete(r, 27))) < 0.1


def test_white_residual_stays_mostly_inside_the_99_percent_band():
    rng = np.random.default_rng(2)
    n = 4000
    sig = {'u': rng.standard_normal(n), 'const': np.ones(n)}
    out = residual_tests(rng.standard_normal(n), sig, DT, 's', max_lag=200)
    assert out['band'] == pytest.approx(2.576 / np.sqrt(n))
    assert out['max_lag'] == pytest.approx(200 * DT)
    assert out['autocorrelation']['fraction_over'] < 0.04      # 1 % expected
    assert out['cross']['u']['fraction_over'] < 0.04
    assert out['untested'] == ['const']


def test_residual_drifting_with_time_is_flagged_against_time():
    data = _record()
    rng = np.random.default_rng(3)
    drift = 0.002 * data.time
    res = compare(data, data.position - drift - 0.001 * rng.standard_normal(len(data)))
    tests = res.correlations
    assert tests['cross']['time']['exceeds']
    assert tests['cross']['time']['max_abs'] > 0.95
    assert tests['flagged'][0] in ('time', 'ambient')      # ambient is a time ramp here
    assert tests['autocorrelation']['exceeds']


def test_residual_following_an_input_with_delay_peaks_at_that_lag():
    data = _record()
    rng = np.random.default_rng(4)
    u = rng.uniform(0, 1, len(data))
    lag = 6
    err = 0.05 * np.concatenate([np.zeros(lag), u[:-lag]]) + 0.002 * rng.standard_normal(len(u))
    tests = residual_tests(err, {'duty noise': u}, DT, 's')
    t = tests['cross']['duty noise']
    assert t['exceeds'] and t['at_lag'] == pytest.approx(lag * DT)
    assert any(a - 1e-9 <= lag * DT <= b + 1e-9 for a, b in t['lags_over'])
    assert t['strength'] > 10


def _static(curves=4):
    from sma_actuator.core.datakinds import StaticData
    u = np.tile(np.concatenate([np.linspace(0, 1, 20), np.linspace(1, 0, 20)]), curves)
    curve = np.repeat(np.arange(curves), 40)
    y = np.tanh(3 * (u - 0.5)) + 0.1 * curve
    return StaticData(u, y, curve)


def test_static_breakdown_per_curve_and_odd_curves_validate():
    data = _static()
    pred = [(c, data.output[data.curve == c] - (0.2 if c == 3 else 0.0)) for c in range(4)]
    res = compare(data, data.flat(pred))
    rows = _rows(res, 'curves')
    assert rows['curve 3 (validation)']['error_share'] == pytest.approx(1.0)
    assert rows['curve 2 (train)']['rmse'] == 0.0
    assert res.scores['train']['rmse'] == 0.0
    assert res.scores['validation']['rmse'] == pytest.approx(np.sqrt(0.5) * 0.2)
    heating = _rows(res, 'thermal')['heating (input rising)']
    assert heating['samples'] == 4 * 20


def test_prediction_length_mismatch_is_an_error():
    data = _record(200)
    with pytest.raises(ValueError, match='prediction has 199 samples, the record 200'):
        compare(data, data.position[:-1])


@pytest.mark.slow
def test_report_writes_html_and_pngs_and_refuses_to_overwrite(tmp_path):
    data = _record(400)
    res = compare(data, data.position - 0.02 * np.sin(data.time))
    out = tmp_path / 'rep'
    diagnosis = {'baseline': {'effects': [], 'validation_nrmse': 0.1},
                 'candidates': [{'effect': 'delay', 'validation_nrmse': 0.02,
                                 'improvement': 0.8, 'significant': True,
                                 'explanation': 'residual <leads> the motion'}],
                 'missing_effect': 'delay'}
    index = write_report(out, res, 'test report', data_line='made up', diagnosis=diagnosis,
                         alternative=('model + delay', data.position))
    page = index.read_text()
    for name in ('time.png', 'residual.png', 'hysteresis.png', 'regimes.png',
                 'correlation.png'):
        assert (out / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
        assert f'src="{name}"' in page
    assert 'residual &lt;leads&gt; the motion' in page          # text is escaped
    assert 'Missing effect: <b>delay</b>' in page
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    with pytest.raises(ReportError, match='already holds a report'):
        write_report(out, res, 'again')
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
    write_report(out, res, 'forced', force=True)
    assert 'forced' in index.read_text()


def _gapped(n=400, gap=(150, 200)):
    """Return a record whose position was not measured over `gap` (lost joint states)."""
    data = _record(n)
    data.scored = np.ones(n, bool)
    data.scored[gap[0]:gap[1]] = False
    return data


def test_a_gap_in_a_record_is_neither_scored_nor_drawn_and_keeps_its_time(tmp_path):
    data = _gapped()
    pred = data.position + 0.01
    pred[~data.scored] += 5.0       # the straight line through the gap is no measurement
    res = compare(data, pred)
    assert res.measured.size == 350 and res.scores['all']['rmse'] == pytest.approx(0.01)
    # the record's events keep their time: the axis steps over the 2.5 s not measured
    np.testing.assert_allclose(res.axis, data.time[data.scored] - data.time[0])
    measured_line = plot_time(res).axes[0].lines[0]
    assert np.isnan(measured_line.get_ydata()).sum() == 1       # the line breaks at the gap
    # a prediction at every sample of the record is drawn at the compared samples
    write_report(tmp_path / 'r', res, 'gap', alternative=('model + delay', pred - 0.01))
    assert (tmp_path / 'r' / 'time.png').is_file()


@pytest.mark.slow
def test_a_diagnosis_report_says_how_far_the_model_is_from_the_noise(tmp_path):
    data = _record(400)
    res = compare(data, data.position - 0.02 * np.sin(data.time))
    named = {'effect': 'delay', 'validation_nrmse': 0.0014, 'train_nrmse': 0.0012,
             'improvement': 0.8, 'significant': True, 'explanation': 'residual leads'}
    doc = {'baseline': {'effects': [], 'validation_nrmse': 0.1, 'train_nrmse': 0.08,
                        'noise_floor_nrmse': 0.001},
           'candidates': [named], 'missing_effect': 'delay'}
    page = write_report(tmp_path / 'named', res, 'named', diagnosis=doc).read_text()
    assert 'validation NRMSE 10.00 % (the measurement noise alone: 0.10 %)' in page
    assert ('<p>with delay the held-out error is 1.4 times what the measurement noise alone '
            'gives: the model explains the data</p>') in page
    named['significant'] = False
    doc['missing_effect'] = None
    page = write_report(tmp_path / 'none', res, 'none', diagnosis=doc).read_text()
    assert ('<p>the held-out error is 100 times what the measurement noise alone gives, the '
            'training error too 80 times: an effect the catalog does not hold') in page


@pytest.mark.slow
def test_a_report_of_rounds_ends_with_what_the_final_model_leaves(tmp_path):
    res = compare(_record(400), _record(400).position)
    first = {'effect': 'delay', 'validation_nrmse': 0.02, 'train_nrmse': 0.015,
             'improvement': 0.8, 'significant': True, 'explanation': 'residual leads'}
    doc = {'baseline': {'effects': [], 'validation_nrmse': 0.1, 'train_nrmse': 0.08,
                        'noise_floor_nrmse': 0.001},
           'candidates': [first], 'missing_effect': 'delay',
           'rounds': [{'added': 'delay', 'validation_nrmse': 0.02},
                      {'added': 'convection', 'validation_nrmse': 0.0012}],
           'final': {'effects': ['delay', 'convection'], 'validation_nrmse': 0.0012,
                     'train_nrmse': 0.0011},
           'rounds_limit': 3}
    page = write_report(tmp_path / 'ended', res, 'ended', diagnosis=doc).read_text()
    # the first round's line, then the rounds: the final model explains the data
    assert 'with delay the held-out error is 20 times' in page
    assert 'round 2: + convection' in page and 'then nothing is significant' in page
    assert ('the held-out error is 1.2 times what the measurement noise alone gives: the '
            'model explains the data') in page
    doc['rounds_limit'] = 2
    page = write_report(tmp_path / 'stopped', res, 'stopped', diagnosis=doc).read_text()
    assert 'stopped after 2 rounds (--rounds)' in page
    assert 'with delay + convection the held-out error is 1.2 times' in page


def test_joined_records_follow_each_other_and_a_gap_keeps_its_length():
    first, second = _gapped(), _record(300, seed=1)
    data = join([('first', first), ('second', second)])
    res = compare(data, data.position)
    assert res.measured.size == 350 + 300
    steps = np.round(np.diff(res.axis) / DT).astype(int)
    # the rest between the records takes no time on the plot; the gap inside one does
    assert steps.tolist() == [1] * 149 + [51] + [1] * (350 + 300 - 151)


@pytest.mark.slow
def test_a_diagnosis_report_scores_only_what_the_fit_was_scored_on(tmp_path):
    """`sma-model batch` writes its reports here: a gap is left out as the fit left it out."""
    data = _gapped()
    data.position[~data.scored] += 1.0      # what the gap holds is no measurement
    fit = fit_model(data)
    index = write_diagnosis_report(tmp_path / 'r', data, Diagnosis(fit, [], None), 'batch',
                                   'one record')
    rmse = part_scores(data, fit.prediction, data.scored)['rmse']
    assert rmse < 0.1
    row = re.search(r'<td class="l">all</td><td>[^<]*</td><td>([^<]*)</td>', index.read_text())
    assert row and float(row.group(1)) == pytest.approx(rmse, rel=1e-3)


def test_static_report_draws_the_curves(tmp_path):
    data = _static()
    res = compare(data, data.flat([(c, data.output[data.curve == c]) for c in range(4)]))
    write_report(tmp_path / 's', res, 'static')
    assert (tmp_path / 's' / 'curves.png').exists()
    assert not (tmp_path / 's' / 'hysteresis.png').exists()
