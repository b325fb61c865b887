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
Workbench engine internals.

The adaptive hysteresis grid, per-wire fatigue identification, the drive-dependent sign of phase
resistance and the counterfactual check (the base refitted on the candidate's grid).
"""
import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from sma_actuator.core import actuator as act
from sma_actuator.core import identification as idn
from sma_actuator.core import play_grids
from sma_actuator.core import scoring
from sma_actuator.core.hysteresis import PlayHysteresis
from sma_actuator.workbench import diagnosis, engine, judging
from sma_actuator.workbench.batch import round_summary
from sma_actuator.workbench.commands.diagnose import diagnosis_lines
from sma_actuator.workbench.effects import CATALOG, Effect, get_effect, register_effect
from support import plant_records
from support.richsim import parse_rig, simulate
from test_core_identification import multilevel_duty

DT = 1.0 / 40.0


def record(params, seconds=300.0, seed=5, noise=0.002):
    rng = np.random.default_rng(seed)
    n = int(seconds / DT)
    da, db = multilevel_duty(n, DT, rng)
    y = act.simulate(params, da, db, DT).position_rad + rng.normal(0, noise, n)
    return idn.DynamicData(np.arange(n) * DT, da, db, y)


def test_mass_points_concentrate_where_the_coarse_weight_is():
    x = np.array([10.0, 60.0, 90.0])
    mass = np.array([0.0, 1.0, 0.0])
    pts = play_grids._mass_points(x, mass, 4.0, 0.0, 100.0, 24)
    assert len(pts) == 24 and np.all(np.diff(pts) >= 0)
    assert pts[0] == 0.0 and pts[-1] == 100.0                   # the even third spans the range
    assert np.sum(np.abs(pts - 60.0) <= 2.0) >= 16              # the rest sits in the mass cell


def test_adaptive_grid_tiles_the_range_for_every_width():
    coarse = PlayHysteresis(np.array([5.0, 10.0]), np.array([50.0, 45.0]),
                            np.array([56.0, 51.0]), np.array([0.3, 0.7]))
    grid, (n_w, n_c) = play_grids.adaptive_grid(coarse, coarse.hi - coarse.lo, 20.0, 100.0, 6, 12)
    assert grid.n_operators == n_w * n_c
    for r in np.unique(grid.r):
        rows = grid.r == r
        edges_lo, edges_hi = grid.lo[rows] + r, grid.hi[rows] + r   # where the element rises
        order = np.argsort(edges_lo)
        assert edges_lo[order][0] == pytest.approx(20.0)
        assert edges_hi[order][-1] == pytest.approx(100.0)
        np.testing.assert_allclose(edges_lo[order][1:], edges_hi[order][:-1])   # no gaps
    # finer where the coarse weight is (both elements rise at 58 degC, cells 6 K wide)
    cells = grid.hi[grid.r == 0] - grid.lo[grid.r == 0]
    centre = 0.5 * (grid.lo[grid.r == 0] + grid.hi[grid.r == 0])
    near, far = np.abs(centre - 58.0) < 3.0, np.abs(centre - 58.0) > 20.0
    assert near.sum() >= 6 and cells[near].max() < 0.1 * cells[far].min()


def test_adaptive_grid_follows_the_output_the_data_moves_not_the_raw_weight():
    # a heavy element whose state hardly moves in training (0.02 K of its 6 K band, rising
    # at 88 degC) and a light one that sweeps its whole band (rising at 58 degC)
    coarse = PlayHysteresis(np.array([5.0, 10.0]), np.array([50.0, 75.0]),
                            np.array([56.0, 81.0]), np.array([0.2, 20.0]))

    def cells_near(span, u):
        grid, _ = play_grids.adaptive_grid(coarse, span, 20.0, 100.0, 6, 12)
        rise = 0.5 * (grid.lo + grid.hi) + grid.r
        return np.sum(np.abs(rise[grid.r == grid.r.min()] - u) < 4.0)

    moved = np.array([6.0, 0.02])
    assert cells_near(moved, 58.0) >= 2 * cells_near(moved, 88.0)
    bands = coarse.hi - coarse.lo      # the whole bands: the heavy element would win
    assert cells_near(bands, 88.0) >= 2 * cells_near(bands, 58.0)


@pytest.mark.slow
def test_base_fit_reaches_the_noise_on_the_plant_models_own_data():
    # regression: on this null record (the package's plant, seed 100) the coarse fit put
    # a large weight on an element near the hottest state; the fine grid followed it and
    # the base stopped at 0.83 % training NRMSE, so diagnose named a phase effect
    d = plant_records.simulate('none', 0, seed=100)
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])
    fit = engine.fit_model(data)
    assert fit.train['nrmse'] < 0.002 and fit.validation['nrmse'] < 0.002
    assert fit.values['tau_s'] == pytest.approx(act.ActuatorParams().tau_s, rel=0.03)


@pytest.mark.slow
def test_the_base_search_tries_other_coarse_grids_while_it_misfits():
    # a null record of one wire against a spring (rich simulator) with no ambient column:
    # from the first coarse grid the search ends at 2.8 times the noise floor (0.54 %
    # training, 0.81 % held out) and diagnose named a sensor polynomial; the model reaches
    # the noise from a coarse grid with fewer centres
    d = simulate('none', magnitude=0.0, excitation='open', duration_s=480.0, rate_hz=40.0,
                 noise_rad=0.002, seed=100, layout='single')
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'], layout='single')
    floor = engine.noise_floor(data)
    first_grid = engine.fit_model(data, search=engine.REFIT_SEARCH)
    assert first_grid.train['nrmse'] > 2.0 * floor
    fit = engine.fit_model(data)
    assert fit.train['nrmse'] <= scoring.NEAR_NOISE * floor
    assert fit.validation['nrmse'] < 0.7 * first_grid.validation['nrmse']


@pytest.mark.slow
def test_the_base_search_keeps_the_best_coarse_grid_that_reaches_the_noise(monkeypatch):
    # the paper's own model: from the first coarse grid the search ends at 1.8 times the
    # noise, and the best of the other two within 1.5 times is kept
    data = record(act.ActuatorParams(), seconds=240.0, seed=9)
    near_noise = scoring.NEAR_NOISE * scoring.record_noise_rms(data)
    searches = []
    one_grid = idn.fit_on_coarse_grid

    def search(*args):
        fit = one_grid(*args)
        searches.append((args[3], fit.train['rmse']))
        return fit
    monkeypatch.setattr(idn, 'fit_on_coarse_grid', search)
    fit = engine.fit_model(data)
    options = idn.SearchOptions()
    assert [grid for grid, _ in searches] == [options.coarse, *options.coarse_alternatives]
    assert searches[0][1] > near_noise
    assert fit.train['rmse'] == min(rmse for _, rmse in searches[1:]) <= near_noise
    # a candidate's refits from scratch, beside its warm one, search the first grid only
    searches.clear()
    task, = judging.candidate_tasks(data, fit, ['latent_heat'])
    judging.judge_candidate(task)
    assert searches and {grid for grid, _ in searches} == {options.coarse}


@pytest.mark.slow
def test_strong_sensor_polynomial_is_fitted_to_the_noise():
    # the plant's strongest potentiometer setting (0.26 rad off at the ends for the old
    # first-order inverse of p in the regression, which left 0.92 % training NRMSE)
    d = plant_records.simulate('sensor_nonlinearity', 2, duration_s=240.0, seed=272)
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])
    base = engine.fit_model(data)
    fit = engine.fit_model(data, ['sensor_nonlinearity'], base_fit=base)
    assert fit.train['nrmse'] < 0.003
    assert fit.validation['nrmse'] < 0.4 * base.validation['nrmse']


@pytest.mark.slow
def test_the_sensor_polynomial_fits_the_same_whatever_the_unit_and_zero():
    # one potentiometer record (rich simulator) read in rad, and as a rig in mm reads it:
    # 8 mm + 5 mm/rad. Expanded about the measured travel the fit is the same; about 0 mm
    # it held the mm record out at 0.64 % against 0.22 % in rad
    d = simulate('sensor_nonlinearity', magnitude=1.5, excitation='open', duration_s=480.0,
                 rate_hz=40, noise_rad=0.002, seed=21)
    fits = []
    for position in (d['position'], 8.0 + 5.0 * d['position']):
        data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], position)
        base = engine.fit_model(data)
        fits.append(engine.fit_model(data, ['sensor_nonlinearity'], base_fit=base))
        assert fits[-1].validation['nrmse'] < 0.3 * base.validation['nrmse']
    rad, mm = fits
    assert mm.validation['nrmse'] == pytest.approx(rad.validation['nrmse'], rel=0.02)
    assert mm.params.sensor_half_span_rad == pytest.approx(5.0 * rad.params.sensor_half_span_rad)
    for k in act.EFFECT_PARAMETERS['sensor_nonlinearity']:
        assert getattr(mm.params, k) == pytest.approx(getattr(rad.params, k), abs=0.01), k


# another rig of the rich simulator: a thicker, longer, slower wire with a warmer loop
RIG_B = {'wire_diameter_m': 200e-6, 'resistance_ohm_per_m': 29.0, 'wire_length_m': 0.3,
         'cooling_tau_s': 2.5, 'i_max_a': 0.6, 'hyst_centre_c': 70.0, 'hyst_width_k': 30.0,
         'pulley_r_m': 0.006, 'strain_max': 0.035, 'duty_max': 0.42}


@pytest.mark.slow
def test_the_refit_from_scratch_tries_every_start_a_fresh_fit_tries():
    # a 0.275 s delay on that rig: from the default start alone, the refit from scratch ends
    # in a poor basin (0.284 s, 0.63 % training NRMSE, worse held out than the base), and on
    # the base grid the 0.3 s start does no better; from scratch at 0.3 s it fits the noise
    d = simulate('delay', magnitude=1.375, excitation='open', duration_s=480.0, rate_hz=40,
                 noise_rad=0.002, seed=221, params=RIG_B)
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'],
                           d['ambient_temperature'])
    diag = diagnosis.diagnose(data, candidates=['delay'])
    assert diag.missing_effect == 'delay'
    named = diag.candidates[0]['fit']
    assert named.values['delay_s'] == pytest.approx(0.2 * 1.375, rel=0.03)
    assert named.validation['nrmse'] < 0.1 * diag.baseline.validation['nrmse']


def test_the_typical_gain_is_the_median_over_held_out_blocks():
    n = 100
    t = np.arange(n) * 0.1
    y = np.sin(t)
    data = idn.DynamicData(t, np.zeros(n), np.zeros(n), y)
    split = idn.Split(50)

    def fit(error):
        return engine.ModelFit([], 'modified', {}, None, None, y + error, split, 0, None)

    base = fit(np.full(n, 0.1))
    # 4 of 5 held-out blocks at a quarter of the base's error, one ten times worse
    err = np.full(n, 0.025)
    err[50:60] = 1.0
    assert judging.typical_gain(data, base, fit(err)) == pytest.approx(0.75)
    rmse = judging.held_out_block_rmse(data, base, fit(err))
    np.testing.assert_allclose(rmse, [[0.1] * 5, [1.0] + [0.025] * 4])
    whole = np.sqrt(np.mean(err[50:] ** 2)) / 0.1
    assert whole > 1.0     # the whole held-out window calls it worse than the base
    assert judging.typical_gain(data, base, fit(np.full(n, 0.2))) == pytest.approx(-1.0)


def test_the_typical_pass_leaves_a_gain_that_quiet_blocks_carry():
    # five held-out blocks of 10 samples; the candidate gains 50 % in the first moving block
    # and in the last two, and loses 10 % in the other two moving ones
    n = 100
    rng = np.random.default_rng(5)
    ramp = np.linspace(-1.0, 1.0, 10)

    def judged(y):
        data = idn.DynamicData(np.arange(n) * 0.1, np.zeros(n), np.zeros(n), y)
        error = np.full(n, 0.1)
        error[50:60], error[80:] = 0.05, 0.05
        error[60:80] = 0.11

        def fit(err, sd, effects=()):
            return engine.ModelFit(list(effects), 'modified', {}, None, None, y + err,
                                   idn.Split(50), 0, sd * rng.standard_normal(50))

        base = fit(np.full(n, 0.1), 0.1)
        entry = {'effect': 'sensor_nonlinearity', 'significant': False, 'bic_change': -50.0,
                 'fit': fit(error, 0.05, ['sensor_nonlinearity']), 'improvement': 0.1,
                 'base_refit': fit(np.full(n, 0.1), 0.1), 'explanation': ''}
        assert judging.typical_gain(data, base, entry['fit']) == pytest.approx(0.5)
        named = diagnosis.typical_pass(data, base, [entry], judging.MIN_IMPROVEMENT)
        return named, judging.moving_block_gains(data, base, entry['fit']), entry

    named, gains, entry = judged(np.concatenate([np.sin(np.arange(50)), np.tile(ramp, 3),
                                                 np.zeros(20)]))
    # three blocks move, and two of them get worse: the quiet ones carry the median
    np.testing.assert_allclose(gains, [0.5, -0.1, -0.1])
    assert named == [] and not entry['significant']
    # the same errors where every block moves: the candidate is better in most of them
    named, gains, entry = judged(np.concatenate([np.sin(np.arange(50)), np.tile(ramp, 5)]))
    assert len(gains) == judging.HELD_OUT_BLOCKS
    assert named == ['sensor_nonlinearity'] and entry['typical_gain'] == pytest.approx(0.5)


def test_bic_counts_independent_samples_on_the_whiter_residual():
    rng = np.random.default_rng(3)
    n = 16000
    noise = 0.002 * rng.standard_normal(n)
    drift = 0.004 * np.linspace(-1.0, 1.0, n)   # a slow drift the base lacks [rad]

    def fit(effects, residual):
        return engine.ModelFit(effects, 'modified', {}, None, None, None, None, 0, residual)

    base = fit([], noise + drift)
    with_drift = fit(['fatigue_drift'], noise)
    long, short = (judging.correlation_length(f.residual) for f in (base, with_drift))
    assert long > 1000 and short <= 2
    # counted on the base residual alone, n / long samples: the drift could never pass
    n_eff = n / long
    alone = judging.bic(with_drift.residual, 4, n_eff) - judging.bic(base.residual, 0, n_eff)
    assert alone > -judging.BIC_MARGIN
    # counted on the whiter residual (the model with the effect), it passes by far
    assert judging.bic_gain(base, with_drift) < -100 * judging.BIC_MARGIN
    assert judging.bic_gain(base, with_drift, long) == judging.bic_gain(base, with_drift)
    # a candidate that leaves the drift in keeps the base's count, and its 2 % lower RSS
    # does not pay for 4 parameters
    shaved = fit(['sensor_nonlinearity'], noise + 0.98 * drift)
    assert judging.correlation_length(shaved.residual) > 1000
    assert judging.bic_gain(base, shaved) > -judging.BIC_MARGIN


def _entry(name, gain, significant, bic_change, train=None):
    """Return a judged candidate entry as `diagnosis.rank_candidates` takes it (training NRMSE)."""
    entry = {'effect': name, 'improvement': gain, 'significant': significant,
             'bic_change': bic_change, 'explanation': name + '.'}
    if train is not None:
        entry['fit'] = SimpleNamespace(train={'nrmse': train})
    return entry


def _ranked(*entries):
    """Return (name, order, entries) of `diagnosis.rank_candidates` on `entries`."""
    diag = diagnosis.rank_candidates(None, list(entries))
    return diag.missing_effect, [c['effect'] for c in diag.candidates], diag.candidates


def test_near_tied_candidates_keep_their_held_out_order_and_say_so():
    # a larger gain that is not significant never goes before a significant one
    name, order, _ = _ranked(_entry('a', 0.9, False, -50.0), _entry('b', 0.3, True, -20.0))
    assert (name, order) == ('b', ['b', 'a'])
    # within 10 % of the best gain: held-out order, whatever the BIC (the parameter count)
    name, order, out = _ranked(_entry('b', 0.56, True, -45.0), _entry('a', 0.61, True, -40.0),
                               _entry('c', 0.20, True, -90.0))
    assert (name, order) == ('a', ['a', 'b', 'c'])
    assert all('Near tie: a, b' in c['explanation'] for c in out[:2])
    assert 'Near tie' not in out[2]['explanation']
    diagnosis.rank_candidates(None, out)   # ranked again (a later pass): said once
    assert out[0]['explanation'].count('Near tie') == 1
    # further apart: no tie is said
    name, order, out = _ranked(_entry('a', 0.61, True, -40.0), _entry('b', 0.50, True, -45.0))
    assert (name, order) == ('a', ['a', 'b'])
    assert not any('Near tie' in c['explanation'] for c in out)


def test_an_effect_that_an_unresolved_candidate_outgains_is_not_named():
    def entry(name, gain, significant, unresolved=None):
        return {'effect': name, 'improvement': gain, 'significant': significant,
                'bic_change': -50.0, 'explanation': name + '.', 'unresolved': unresolved,
                'validation_nrmse': 0.01 * (1.0 - gain)}

    # at 10 Hz a 72 ms delay (below one sample) fits better than the significant lag
    why = ('the fitted delay 72 ms is below one sample period (100 ms)',
           'at this sample rate the two are not told apart; record faster')
    diag = diagnosis.rank_candidates(None, [entry('delay', 0.60, False, why),
                                            entry('fast_dynamics', 0.46, True),
                                            entry('convection', 0.05, False)])
    assert diag.missing_effect is None
    lag = next(c for c in diag.candidates if c['effect'] == 'fast_dynamics')
    assert not lag['significant'] and lag['rival'] == 'delay'
    assert ('Not named: delay fits the held-out window better (+60 % against +46 %)'
            in lag['explanation'])
    assert f'({why[0]}): {why[1]} to separate them.' in lag['explanation']
    doc = {'baseline': {'effects': [], 'validation_nrmse': 0.01, 'train_nrmse': 0.01},
           'candidates': [diagnosis.candidate_json(c) for c in diag.candidates],
           'missing_effect': diag.missing_effect}
    assert doc['candidates'][0]['not_resolved'] == why[0]
    assert doc['candidates'][1]['rival'] == 'delay'
    assert any('fast_dynamics passed every check, but delay' in line
               for line in diagnosis_lines(doc, 'modified'))
    # ranked again (a later pass): said once, still not named
    assert diagnosis.rank_candidates(None, diag.candidates).missing_effect is None
    assert lag['explanation'].count('fits the held-out window better') == 1
    # within a near tie of it (25 Hz: a 36 ms delay +48 %, the lag +45 %): named, rival said
    diag = diagnosis.rank_candidates(None, [entry('delay', 0.48, False, why),
                                            entry('fast_dynamics', 0.45, True)])
    assert diag.missing_effect == 'fast_dynamics'
    assert diag.candidates[0]['explanation'] == (
        f'fast_dynamics. delay fits the held-out window better (+48 % against +45 %) but is '
        f'not resolved ({why[0]}): {why[1]} to separate them.')
    # an unresolved candidate that gains less: named, nothing said
    diag = diagnosis.rank_candidates(None, [entry('delay', 0.40, False, why),
                                            entry('fast_dynamics', 0.86, True)])
    assert diag.missing_effect == 'fast_dynamics'
    assert diag.candidates[0]['explanation'] == 'fast_dynamics.'


def _judged(name, bic_change, train, held_out, **values):
    """Return a judged entry whose refit has these training and held-out NRMSE and values."""
    fit = SimpleNamespace(train={'nrmse': train}, validation={'nrmse': held_out}, values=values)
    return dict(_entry(name, 0.0, False, bic_change), fit=fit)


def _lead(train, held_out, *entries, named=None):
    """Return `diagnosis.training_lead` over a base with these NRMSE; noise floor 0.19 %, 40 Hz."""
    base = SimpleNamespace(train={'nrmse': train}, validation={'nrmse': held_out})
    diag = diagnosis.Diagnosis(base, list(entries), named, noise_floor_nrmse=0.0019)
    return diagnosis.training_lead(SimpleNamespace(dt=0.025), diag, judging.MIN_IMPROVEMENT)


def test_a_training_window_the_held_out_one_cannot_judge_gives_a_lead_not_a_name():
    # one slow wire (τ 6 s) with a 0.28 s delay, as measured: the base fits training at
    # 1.58 % and holds out at 0.20 %, the noise; the delay refit fits training to the noise
    delay = _judged('delay', -55430.0, 0.0020, 0.0020, delay_s=0.276)
    lag = _judged('fast_dynamics', -3795.0, 0.0068, 0.0021, tau_fast_s=0.30)
    lead = _lead(0.0158, 0.0020, lag, delay)
    assert lead == {'effect': 'delay', 'train_nrmse': 0.0020, 'validation_nrmse': 0.0020,
                    'bic_change': -55430.0}
    # a delay under one sample period is alignment, not a lead
    short = _judged('delay', -55430.0, 0.0020, 0.0020, delay_s=0.010)
    assert _lead(0.0158, 0.0020, lag, short)['effect'] == 'fast_dynamics'
    # none where the held-out window can judge, training is near the noise, an effect is
    # named, the refit breaks the held-out window, or training gains too little
    assert _lead(0.0158, 0.0040, delay) is None
    assert _lead(0.0035, 0.0020, delay) is None
    assert _lead(0.0158, 0.0020, delay, named='delay') is None
    assert _lead(0.0158, 0.0020, _judged('delay', -55430.0, 0.0020, 0.0035, delay_s=0.276)) is None
    assert _lead(0.0158, 0.0020, _judged('convection', -400.0, 0.0140, 0.0020,
                                         convection_exponent=0.1)) is None
    # the JSON and the batch's round summary carry it beside a null missing_effect
    base = SimpleNamespace(effects=[], train={'nrmse': 0.0158}, validation={'nrmse': 0.0020})
    diag = diagnosis.Diagnosis(base, [delay], None, noise_floor_nrmse=0.0019, training_lead=lead)
    assert diag.to_json()['training_lead'] == lead and diag.to_json()['missing_effect'] is None
    assert round_summary(diag, {})['training_lead'] == 'delay'


def test_a_delay_and_a_lag_both_significant_are_ranked_by_their_training_fit():
    # a 0.3 s delay on wires that follow the paper's cosine law, which the PI base misfits
    # held out (`bench_major_loop_law.py --seed 1`): the lag gains more held out, the delay
    # fits training far better; a better-fitting effect of another kind keeps its place
    lag, delay = (_entry('fast_dynamics', 0.64, True, -776.0, 0.0118),
                  _entry('delay', 0.46, True, -1505.0, 0.0063))
    name, order, out = _ranked(lag, delay, _entry('convection', 0.30, True, -2000.0, 0.005),
                               _entry('latent_heat', 0.90, False, -9000.0, 0.004))
    assert (name, order) == ('delay', ['delay', 'fast_dynamics', 'convection', 'latent_heat'])
    said = ('Ranked before fast_dynamics, which gains more held out (+64 % against +46 %): '
            'it fits the training window clearly better (NRMSE 0.63 % against 1.18 %, BIC '
            'change -1505.0 against -776.0)')
    assert said in out[0]['explanation']
    assert out[1]['explanation'] == 'fast_dynamics.'
    diagnosis.rank_candidates(None, out)   # ranked again (a later pass): said once
    assert out[0]['explanation'].count('Ranked before') == 1
    # an effect of another kind that gains most stays first; the two retarders swap behind it
    name, order, _ = _ranked(_entry('convection', 0.80, True, -100.0, 0.005),
                             _entry('fast_dynamics', 0.64, True, -776.0, 0.0118),
                             _entry('delay', 0.46, True, -1505.0, 0.0063))
    assert (name, order) == ('convection', ['convection', 'delay', 'fast_dynamics'])
    # the held-out leader fits training better too: held-out order, nothing said
    name, order, out = _ranked(_entry('delay', 0.55, True, -180.0, 0.002),
                               _entry('fast_dynamics', 0.22, True, -114.0, 0.003))
    assert (name, order) == ('delay', ['delay', 'fast_dynamics'])
    assert [c['explanation'] for c in out] == ['delay.', 'fast_dynamics.']
    # a 0.05 s lag on a thin fast wire at 50 Hz (the third rig, M 0.33): the delay's BIC is
    # lower, but both fit training at 0.14 %: held-out order, the lag first
    name, order, out = _ranked(_entry('fast_dynamics', 0.58, True, -22354.8, 0.00141),
                               _entry('delay', 0.52, True, -22413.6, 0.00140))
    assert (name, order) == ('fast_dynamics', ['fast_dynamics', 'delay'])
    assert not any('Ranked before' in c['explanation'] for c in out)
    # a rival that is not significant is not ranked by its training fit
    name, order, _ = _ranked(_entry('fast_dynamics', 0.64, True, -776.0, 0.0118),
                             _entry('delay', 0.46, False, -1505.0, 0.0063))
    assert (name, order) == ('fast_dynamics', ['fast_dynamics', 'delay'])


@pytest.mark.slow
def test_a_delay_held_out_behind_one_excursion_is_named_by_its_typical_gain():
    # a 0.275 s delay with stress coupling in the independent simulator: in the first 24 s
    # held out the shaft goes to -0.98 rad, beyond the -0.77 rad training saw, and every
    # model is off by about 0.18 rad there; everywhere else the delay model is at the noise
    d = simulate('delay', magnitude=1.375, excitation='open', duration_s=480.0, rate_hz=40,
                 noise_rad=0.002, seed=706, also=[('stress_coupling', 1.15)])
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'],
                           d['ambient_temperature'])
    diag = diagnosis.diagnose(data, candidates=['delay'])
    named = diag.candidates[0]
    assert diag.missing_effect == 'delay'
    assert named['improvement'] < 0.2 <= named['typical_gain']
    assert named['fit'].values['delay_s'] == pytest.approx(0.275, rel=0.05)
    assert 'typical held-out gain' in named['explanation']


def _plant_record_with(first, second, seed):
    """Return a 480 s record of the package's plant with two effects at their middle level."""
    effects = plant_records.EFFECTS
    d = plant_records.simulate_with(dict(effects[first][1], **effects[second][1]), seed=seed)
    return idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])


@pytest.mark.slow
def test_a_candidate_held_in_the_bases_basin_is_refitted_from_scratch():
    # two effects at once in the plant (delay 0.3 s and stress coupling 20 K): the base
    # misses by 8.3 % held out, and each candidate refitted warm from it stays near there
    # (stress coupling 8.2 %, delay 7.7 %), so the first pass names nothing
    data = _plant_record_with('delay', 'stress_coupling', seed=706)
    diag = diagnosis.diagnose(data, candidates=['stress_coupling', 'delay'])
    assert diag.missing_effect == 'stress_coupling'
    named = diag.candidates[0]['fit']
    assert 'refitted from scratch' in diag.candidates[0]['explanation']
    assert named.validation['nrmse'] < 0.3 * diag.baseline.validation['nrmse']
    assert named.values['stress_k'] == pytest.approx(20.0, rel=0.5)


def test_a_refit_from_scratch_at_the_noise_is_judged_before_a_warm_one():
    data = record(act.ActuatorParams(), seconds=60.0)
    noise = scoring.record_noise_rms(data)

    def fit(train_rmse):
        return SimpleNamespace(train={'rmse': train_rmse * noise})

    # at the noise the warm refit's better training is noise it fits: the search's fit stands
    assert not engine.prefer_warm(data, warm=fit(1.0), scratch=fit(1.4))
    # short of the noise, the better training fit of the two
    assert engine.prefer_warm(data, warm=fit(1.0), scratch=fit(2.0))
    assert not engine.prefer_warm(data, warm=fit(3.0), scratch=fit(2.0))


@pytest.mark.slow
def test_a_drift_the_bases_grid_absorbs_is_named_from_scratch():
    # strong fatigue in the plant (0.2 rad zero drift, 30 % stroke loss over 200 cycles):
    # the base's search ends on another coarse grid, 1.4 times the noise in training and
    # 0.42 % held out; the fatigue refit warm on that grid trains better still but holds
    # out worse (0.47 %), the one from scratch trains at the noise and holds out 0.28 %
    order = [e for e in plant_records.EFFECTS if e != 'none']
    d = plant_records.simulate('fatigue_drift', 2, seed=202 + 10 * order.index('fatigue_drift'))
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])
    diag = diagnosis.diagnose(data, candidates=['fatigue_drift'])
    base, named = diag.baseline, diag.candidates[0]
    assert base.train['nrmse'] <= scoring.NEAR_NOISE * diag.noise_floor_nrmse
    assert diag.missing_effect == 'fatigue_drift', named['explanation']
    assert 'from scratch (it fits the training window to the noise' in named['explanation']
    assert named['fit'].validation['nrmse'] < 0.8 * base.validation['nrmse']


@pytest.mark.slow
def test_unequal_wires_are_found_from_either_side_of_the_equal_pair():
    # wire b heats 1.4 times as much and has 0.8 times the time constant, beside a 0.6 s fast
    # lag: from the equal pair alone the search traded heating gain for stroke and ended
    # at the stroke ratio's bound (2.0), 4.8 % in training
    data = _plant_record_with('fast_dynamics', 'asymmetric_wires', seed=709)
    fit = engine.fit_model(data, ['asymmetric_wires', 'fast_dynamics'])
    assert fit.values['gain_ratio_b'] == pytest.approx(1.4, rel=0.05)
    assert fit.values['stroke_ratio_b'] == pytest.approx(1.0, rel=0.05)
    assert fit.validation['nrmse'] < 0.005


@pytest.mark.slow
def test_strong_latent_heat_is_named_from_its_own_grid():
    # the plant's strongest latent heat (25 K per unit contraction): refitted on the base
    # grid from a small start the search stopped at 8 K (+8 % held-out, not named)
    d = plant_records.simulate('latent_heat', 2, duration_s=240.0, seed=252)
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])
    diag = diagnosis.diagnose(data, candidates=['latent_heat', 'convection'])
    assert diag.missing_effect == 'latent_heat'
    named = next(c for c in diag.candidates if c['effect'] == 'latent_heat')
    # the loop's fitted width trades against λ: 240 s fit the training window to the noise
    # from about 15 K up, so λ is known to within a half here
    assert named['fit'].values['latent_heat_k'] == pytest.approx(25.0, rel=0.5)
    assert named['fit'].validation['nrmse'] < 0.6 * diag.baseline.validation['nrmse']


@pytest.mark.slow
def test_fatigue_of_each_wire_is_identified_from_its_own_cycles():
    truth = act.ActuatorParams(fatigue_stroke=0.3, fatigue_cycles=12.0,
                               fatigue_offset_rad=-0.1, fatigue_offset_b_rad=0.04)
    data = record(truth)
    base = engine.fit_model(data, ())
    fit = engine.fit_model(data, ['fatigue_drift'], base_fit=base)
    assert fit.validation['nrmse'] < 0.5 * base.validation['nrmse']
    assert fit.values['fatigue_stroke'] == pytest.approx(0.3, abs=0.06)
    assert fit.values['fatigue_cycles'] == pytest.approx(12.0, rel=0.35)
    drift = fit.values['fatigue_offset_rad'] - fit.values['fatigue_offset_b_rad']
    assert drift == pytest.approx(-0.14, abs=0.04)


def test_phase_resistance_sign_follows_the_drive():
    eff = get_effect('phase_resistance')
    limited = act.ActuatorParams()                   # 5 V / 13.75 ohm > 0.35 A: current limited
    lo, hi, start = eff.bounds(limited)['phase_kappa']
    assert lo == 0.0 and hi > 0 and lo <= start <= hi
    voltage = act.ActuatorParams(supply_v=3.0)       # 0.22 A < 0.35 A: P = V^2 / R
    lo, hi, start = eff.bounds(voltage)['phase_kappa']
    assert hi == 0.0 and lo < 0 and lo <= start <= hi


@pytest.mark.slow
def test_the_base_refitted_on_the_candidates_grid_does_not_reach_a_real_effects_gain():
    data = record(act.ActuatorParams(delay_s=0.25), seconds=240.0, seed=8)
    base = engine.fit_model(data, ())
    fit = engine.fit_model(data, ['delay'], base_fit=base)
    v_off = judging.regridded_base(data, base, fit, get_effect('delay')).validation['nrmse']
    assert fit.validation['nrmse'] < 0.5 * base.validation['nrmse']
    assert v_off > 2.0 * fit.validation['nrmse']      # without the delay, the gain is gone
    assert judging.regridded_base(data, base, fit, get_effect('saturation')) is None


@pytest.mark.slow
def test_a_gain_the_regridded_base_fits_as_well_in_training_is_not_the_effects():
    # weak stress coupling at 25 Hz: nearly all held-out error is one transient, and a
    # sensor polynomial on a new grid bends it its way (+39 % held out, BIC -225 against
    # the base), but the base refitted on that grid fits training as well (0.16 %)
    d = simulate('stress_coupling', magnitude=0.3, excitation='open', duration_s=360.0,
                 rate_hz=25.0, noise_rad=0.002, seed=260)
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'],
                           d['ambient_temperature'])
    diag = diagnosis.diagnose(data, candidates=['sensor_nonlinearity'], jobs=1)
    entry = diag.candidates[0]
    assert entry['improvement'] > 0.2 and entry['bic_change'] < -judging.BIC_MARGIN
    assert judging.bic_gain(entry['base_refit'], entry['fit']) > -judging.BIC_MARGIN
    assert diag.missing_effect is None
    assert 'the grid, not the effect, carries the gain' in entry['explanation']


@pytest.mark.slow
def test_a_gain_from_a_few_moving_held_out_stretches_is_not_an_effect():
    # a null record of another rig (125 um, 0.2 m, 1 s cooling, loop at 55 C, 26 C, 30 Hz):
    # the convection refit leaves the exponent at about 0, gains 20 % over the whole
    # held-out window and passes BIC and the regridded base, but of the five held-out
    # blocks, all of which move, two carry the gain and three get worse
    rig = parse_rig(['wire_diameter_m=125e-6', 'resistance_ohm_per_m=80', 'wire_length_m=0.2',
                     'cooling_tau_s=1.0', 'hyst_centre_c=55', 'hyst_width_k=22',
                     'hyst_centre_sd_k=2.0', 'hyst_width_sd_k=3.5', 'i_max_a=0.25',
                     'supply_v=6', 'pulley_r_m=0.0045', 'strain_max=0.038',
                     'duty_max=0.55', 'ambient_c=26', 'stress_self_weight=0.5'])
    d = simulate('none', magnitude=0.0, excitation='open', duration_s=480.0, rate_hz=30.0,
                 noise_rad=0.002, seed=100, params=rig)
    data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'],
                           d['ambient_temperature'])
    base = engine.fit_model(data)
    task, = judging.candidate_tasks(data, base, ['convection'])
    entry = judging.judge_candidate(task)
    assert abs(entry['fit'].values['convection_exponent']) < 0.01
    assert entry['improvement'] >= judging.MIN_IMPROVEMENT
    assert entry['bic_change'] < -judging.BIC_MARGIN
    assert judging.bic_gain(entry['base_refit'], entry['fit']) < -judging.BIC_MARGIN
    gains = judging.moving_block_gains(data, base, entry['fit'])
    assert len(gains) == judging.HELD_OUT_BLOCKS
    assert np.sum(gains < 0) >= 3
    assert not entry['significant']
    assert 'so a few stretches, not the effect, carry the gain' in entry['explanation']
    assert diagnosis.diagnose(data, base, candidates=['convection'], jobs=1).missing_effect is None


@pytest.fixture(scope='module')
def poor_base():
    """Return a record of the paper's model and a poor fit of it (stuck in a wrong minimum)."""
    data = record(act.ActuatorParams(), seconds=240.0, seed=9)
    # the paper's model fitted to a rig 8 K warmer: a poor fit of this one, as a fit stuck
    # in a wrong minimum would be
    warmer = engine.fit_model(record(act.ActuatorParams(ambient_c=30.0), 240.0, seed=9), ())
    pred = warmer.simulate(data)
    train, validation = engine.rescore(data, pred, warmer.split)
    mask = data.split_masks(warmer.split)[0]
    return data, dataclasses.replace(warmer, prediction=pred, train=train,
                                     validation=validation,
                                     residual=pred[mask] - data.position[mask])


@pytest.mark.slow
def test_a_better_fit_of_the_base_found_by_a_counterfactual_replaces_the_base(poor_base):
    data, poor = poor_base
    kept = diagnosis.diagnose(data, base=poor, candidates=['convection'], rebase=0)
    assert kept.baseline is poor and not kept.refitted
    diag = diagnosis.diagnose(data, base=poor, candidates=['convection'])
    assert diag.missing_effect is None and diag.baseline.effects == []
    assert diag.baseline.validation['nrmse'] < 0.1 * poor.validation['nrmse']
    assert 'refitted from where the convection refit ended' in diag.to_json()['baseline'][
        'refitted']
    # the batch's round summary keeps why, and the time of the refits judged before
    summary = round_summary(diag, {})
    assert summary['refitted'] == diag.refitted and round_summary(kept, {})['refitted'] is None
    assert summary['seconds'] > diag.candidates[0]['seconds'] > 0


@pytest.mark.slow
def test_an_effect_named_against_a_poor_base_yields_to_a_better_fit_of_the_base(poor_base):
    # the record holds no effect; against the poor base phase resistance gains held out
    data, poor = poor_base
    named = diagnosis.diagnose(data, base=poor, candidates=['phase_resistance'], rebase=0)
    assert named.missing_effect == 'phase_resistance'
    # latent heat's counterfactual (the base refitted from its refit) predicts better than
    # the named effect: the gain was the poor base's, and diagnose starts again from it
    diag = diagnosis.diagnose(data, base=poor, candidates=['phase_resistance', 'latent_heat'])
    assert diag.missing_effect is None and diag.baseline.effects == []
    assert 'refitted from where the latent_heat refit ended' in diag.refitted
    assert diag.baseline.validation['nrmse'] < named.candidates[0]['validation_nrmse']


def stand_in_fit(train_nrmse, validation_nrmse):
    """Return the scores `diagnosis.better_base` reads of a fit (RMSE = NRMSE, span 1)."""
    return SimpleNamespace(train={'rmse': train_nrmse, 'nrmse': train_nrmse},
                           validation={'nrmse': validation_nrmse})


def test_a_named_effect_yields_to_a_better_base_only_by_a_clear_held_out_margin():
    # the 25 Hz record with convection and a current limit, round 2: a base refitted from a
    # counterfactual fits training far better, and holds out about as well as convection
    base, refit = stand_in_fit(0.0049, 0.0022), stand_in_fit(0.0018, 0.0012)
    entries = [{'effect': 'sensor_nonlinearity', 'base_refit': refit},
               {'effect': 'convection', 'validation_nrmse': 0.0013}]
    bar = 1.0 - judging.MIN_IMPROVEMENT
    assert diagnosis.better_base(base, entries, judging.MIN_IMPROVEMENT)[0] is refit
    # convection's own model fits training at 0.11 %, better than the refit's 0.18 %
    for named_nrmse, replaced in ((0.0013, False), (1.01 * 0.0012 / bar, True)):
        better = diagnosis.better_base(base, entries, judging.MIN_IMPROVEMENT,
                                       named={'effect': 'convection',
                                              'validation_nrmse': named_nrmse,
                                              'fit': stand_in_fit(0.0011, named_nrmse)})
        assert (better is not None) == replaced
    # a refit that fits training less than MIN_IMPROVEMENT better is no better fit at all
    close = [{'effect': 'delay', 'base_refit': stand_in_fit(0.0049 * (bar + 0.01), 0.0012)}]
    assert diagnosis.better_base(base, close, judging.MIN_IMPROVEMENT) is None


def test_a_named_effect_yields_to_a_base_fit_that_beats_its_model_in_training_and_held_out():
    # one slow wire (τ 6 s) with convection M 1.2: `sensor_nonlinearity` named at 1.40 %
    # held out, its model at 1.29 % in training, while the base refitted from the
    # `fast_dynamics` refit fits training at 0.23 % and holds out 1.20 % (14 % better only)
    base, refit = stand_in_fit(0.0140, 0.0209), stand_in_fit(0.0023, 0.0120)
    entries = [{'effect': 'fast_dynamics', 'base_refit': refit}]
    bar = 1.0 - judging.MIN_IMPROVEMENT

    def named(train_nrmse, validation_nrmse):
        return {'effect': 'sensor_nonlinearity', 'validation_nrmse': validation_nrmse,
                'fit': stand_in_fit(train_nrmse, validation_nrmse)}

    assert diagnosis.better_base(base, entries, judging.MIN_IMPROVEMENT,
                                 named=named(0.0129, 0.0140))[0] is refit
    # the named model fitting training within the bar of the refit keeps its name ...
    assert diagnosis.better_base(base, entries, judging.MIN_IMPROVEMENT,
                                 named=named(0.99 * 0.0023 / bar, 0.0140)) is None
    # ... and so does one that holds out better than the refit
    assert diagnosis.better_base(base, entries, judging.MIN_IMPROVEMENT,
                                 named=named(0.0129, 0.0119)) is None


def test_a_named_effect_yields_to_one_that_outfits_it_from_a_better_base():
    # the default rig under `excite`'s design, sensor polynomial M 0.45: `asymmetric_wires`
    # is named against a base at 1.34 % training / 1.87 % held out; the base refitted from
    # the convection refit fits 0.34 % / 0.38 %, which the named model still beats
    base, refit = stand_in_fit(0.0134, 0.0187), stand_in_fit(0.0034, 0.0038)
    asym = {'effect': 'asymmetric_wires', 'validation_nrmse': 0.0026,
            'fit': stand_in_fit(0.0024, 0.0026), 'seconds': 5.0}
    entries = {'asymmetric_wires': asym,
               'convection': {'effect': 'convection', 'base_refit': refit, 'seconds': 7.0}}
    assert diagnosis.better_base(base, list(entries.values()), judging.MIN_IMPROVEMENT,
                                 named=asym) is None
    bar = 1.0 - judging.MIN_IMPROVEMENT
    bases = []

    def opinion(name, train_nrmse, validation_nrmse):
        """Return the diagnosis from the better base, naming `name` (or nothing)."""
        def rediagnose(better):
            bases.append(better)
            entry = {'effect': name or 'sensor_nonlinearity', 'seconds': 3.0,
                     'validation_nrmse': validation_nrmse,
                     'fit': stand_in_fit(train_nrmse, validation_nrmse)}
            return diagnosis.Diagnosis(better, [entry], name)
        first = diagnosis.Diagnosis(base, list(entries.values()), 'asymmetric_wires')
        return first, diagnosis.second_opinion(first, entries, judging.MIN_IMPROVEMENT,
                                               rediagnose)

    # diagnosed from there, the polynomial's model fits 0.17 % / 0.24 %: it stands
    first, diag = opinion('sensor_nonlinearity', 0.0017, 0.0024)
    assert bases == [refit] and diag is not first and diag.baseline is refit
    assert diag.missing_effect == 'sensor_nonlinearity' and diag.earlier_seconds == 12.0
    assert 'sensor_nonlinearity outfits asymmetric_wires' in diag.refitted
    # the named model stands where the other holds out worse, trains within the bar of
    # it, or where the better base names it again or nothing
    for name, train, held_out in (('sensor_nonlinearity', 0.0017, 0.0027),
                                  ('sensor_nonlinearity', 1.01 * bar * 0.0024, 0.0024),
                                  ('asymmetric_wires', 0.0017, 0.0024), (None, 0.0017, 0.0024)):
        first, diag = opinion(name, train, held_out)
        assert diag is first and diag.missing_effect == 'asymmetric_wires'
        assert diag.earlier_seconds == 3.0 and not diag.refitted
    # without a better fit of the base, diagnose does not run again
    del bases[:]
    entries['convection']['base_refit'] = stand_in_fit(0.0134 * (bar + 0.01), 0.0038)
    first, diag = opinion('sensor_nonlinearity', 0.0017, 0.0024)
    assert diag is first and bases == []


class DeadTime(Effect):
    """PWM dead time d0: d' = max(d - d0, 0) / (1 - d0) (a plug-in with its own parameter)."""

    name = 'test_dead_time'
    parameters = {'dead_duty': (0.0, 0.4, 0.05)}

    def transform_inputs(self, duty_a, duty_b, ambient, values):
        d0 = values['dead_duty']
        return (np.clip((duty_a - d0) / (1 - d0), 0, 1),
                np.clip((duty_b - d0) / (1 - d0), 0, 1), ambient)


def dead_time_record(dead_duty=0.2, seed=4, duration_s=240.0):
    """Return a plant record whose PWM loses the first `dead_duty` of every period."""
    rng = np.random.default_rng(seed)
    n = int(duration_s / DT)
    da, db = multilevel_duty(n, DT, rng)
    heat = [np.clip((d - dead_duty) / (1 - dead_duty), 0, 1) for d in (da, db)]
    y = act.simulate(act.ActuatorParams(), heat[0], heat[1], DT).position_rad
    return idn.DynamicData(np.arange(n) * DT, da, db, y + rng.normal(0, 0.002, n))


@pytest.mark.slow
def test_a_plugin_is_judged_against_the_base_refitted_without_it():
    data = dead_time_record()
    register_effect(DeadTime)
    try:
        diag = diagnosis.diagnose(data, candidates=['test_dead_time', 'delay'])
        top = diag.candidates[0]
        assert diag.missing_effect == 'test_dead_time' and top['improvement'] > 0.3
        assert "for the base refitted on the candidate's grid" in top['explanation']
        assert top['base_refit'].validation['nrmse'] > 2.0 * top['validation_nrmse']
    finally:
        CATALOG.pop('test_dead_time', None)


def test_narrow_bands_keep_the_training_run_and_saturate_beyond_it():
    params = act.ActuatorParams()
    rng = np.random.default_rng(8)
    n = int(120 / DT)
    da, db = multilevel_duty(n, DT, rng)
    da, db = 0.5 * da, 0.5 * db                                  # training: mild heating only
    amb = np.full(n, params.ambient_c)
    narrow = play_grids.narrow_bands(params, da, db, amb, DT)
    h, hn = params.hysteresis, narrow.hysteresis
    assert np.all(hn.lo >= h.lo) and np.all(hn.hi <= h.hi) and np.any(hn.hi < h.hi)
    np.testing.assert_array_equal(act.simulate(narrow, da, db, DT).position_rad,
                                  act.simulate(params, da, db, DT).position_rad)
    # hotter than anything in training: the full model contracts further, the narrowed one
    # stops where the training data stopped
    hot = np.r_[da, np.full(400, 1.0)], np.r_[db, np.zeros(400)]
    full_end = act.simulate(params, *hot, DT).position_rad[-1]
    narrow_end = act.simulate(narrow, *hot, DT).position_rad[-1]
    trained_max = act.simulate(params, da, db, DT).position_rad.max()
    assert narrow_end <= trained_max + 1e-9 < full_end


@pytest.mark.parametrize('delay_s', [0.0, 0.3137])
def test_regressors_at_the_rows_equal_the_full_rate_columns(delay_s):
    params = act.ActuatorParams(delay_s=delay_s)
    data = record(act.ActuatorParams(), seconds=60.0)
    grid = play_grids.play_grid(20.0, 120.0, 'modified', 4, 6)
    prob = idn._Problem(idn.Setup(data, params, {'tau_s': None}, {}, 2000, 40), grid)
    rows = slice(40, 2000, 3)
    full = prob.regressors(params.with_changes(delay_s=0.0), 2000)[0]
    if delay_s:
        full = np.column_stack([act.delay_signal(c, DT, delay_s) for c in full.T])
    np.testing.assert_allclose(prob.regressors(params, 2000, rows)[0], full[rows], atol=1e-12)


class OwnGrid(Effect):
    """Test plug-in: a constant offset of the ambient that needs its own grid."""

    name = 'test_own_grid'
    parameters = {'ambient_shift': (-5.0, 5.0, 0.0)}
    own_grid = True

    def transform_inputs(self, duty_a, duty_b, ambient, values):
        return duty_a, duty_b, ambient + values['ambient_shift']

    def scratch_start(self, params):
        return {'ambient_shift': 2.5}

    def scratch_bounds(self, params):
        return {'ambient_shift': (1.0, 5.0, 2.5)}


@pytest.mark.slow
def test_the_pass_from_scratch_runs_only_where_the_base_is_short_of_the_noise():
    # neither plant record names one of these candidates: the null record's base fits to
    # the noise, so a refit from scratch has nothing to gain; with a delay the base is
    # far from it, and the second pass runs
    candidates = ['sensor_nonlinearity', 'current_limit']
    for effect, level, at_noise in (('none', 0, True), ('delay', 1, False)):
        d = plant_records.simulate(effect, level, duration_s=240.0, seed=100)
        data = idn.DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])
        base = engine.fit_model(data, ())
        stages = []
        diag = diagnosis.diagnose(data, base=base, candidates=candidates,
                                  progress=lambda i, n, stage: stages.append(stage))
        assert diag.missing_effect is None, diag.candidates
        assert diagnosis.at_noise(base, data, judging.MIN_IMPROVEMENT) is at_noise
        assert ('candidates from scratch' in stages) is not at_noise, stages


@pytest.mark.slow
def test_own_grid_effects_are_also_refitted_from_scratch(monkeypatch):
    data = record(act.ActuatorParams(), seconds=120.0)
    base = engine.fit_model(data, ())
    grids, starts, frees = [], [], []
    real = engine.fit_dynamic

    def spy(*args, **kw):
        grids.append(kw.get('grid'))
        starts.append(kw.get('start'))
        frees.append(kw.get('free'))
        return real(*args, **kw)

    monkeypatch.setattr(engine, 'fit_dynamic', spy)
    register_effect(OwnGrid)
    try:
        engine.fit_model(data, ['sensor_nonlinearity'], base_fit=base)
        assert all(g is base.grid for g in grids)                 # warm starts only
        grids.clear()
        starts.clear()
        frees.clear()
        engine.fit_model(data, ['test_own_grid'], base_fit=base)
        assert grids[0] is base.grid and grids[-1] is None        # warm, then from scratch
        assert starts[0]['ambient_shift'] == 0.0 and starts[-1]['ambient_shift'] == 2.5
        # warm from the base's time constant; from scratch over the coarse stage's spread
        assert starts[0]['tau_s'] == base.values['tau_s'] and 'tau_s' not in starts[-1]
        # the scratch bounds apply to the refit from scratch only
        assert frees[0]['ambient_shift'] == (-5.0, 5.0, 0.0)
        assert frees[-1]['ambient_shift'] == (1.0, 5.0, 2.5)
    finally:
        CATALOG.pop('test_own_grid', None)


@pytest.mark.slow
def test_a_trial_from_scratch_at_the_noise_stands_before_a_warm_trial_alike_in_training(
        monkeypatch):
    # of an own-grid candidate's trials, the one from scratch at the noise (1.4 times it)
    # stands before a warm one that trains alike (1.3 times); a warm trial that trains
    # clearly better (by NEAR_TIE: 1.0 against 1.4 times) stands, as does one that trains
    # better than a trial from scratch off the noise (2 times)
    data = record(act.ActuatorParams(), seconds=120.0)
    base = engine.fit_model(data, ())
    noise = scoring.record_noise_rms(data)
    real = engine.fit_dynamic

    def training_at(times_warm, times_scratch):
        def spy(*args, **kw):
            trial = real(*args, **kw)
            times = times_warm if kw.get('grid') is base.grid else times_scratch
            return dataclasses.replace(trial, train=dict(trial.train, rmse=times * noise))
        return spy

    register_effect(OwnGrid)
    try:
        for warm, scratch, from_scratch in ((1.3, 1.4, True), (1.0, 1.4, False),
                                            (1.0, 2.0, False)):
            monkeypatch.setattr(engine, 'fit_dynamic', training_at(warm, scratch))
            fit = engine.fit_model(data, ['test_own_grid'], base_fit=base)
            assert (fit.grid is not base.grid) is from_scratch, (warm, scratch)
    finally:
        CATALOG.pop('test_own_grid', None)


def test_fast_dynamics_from_scratch_keeps_the_base_time_constant_the_slow_lag():
    # the two lags in series are interchangeable; from scratch tau stays >= tau_base / 2,
    # so tau >= tau_fast whenever the pair keeps the base fit's mean delay tau + tau_fast
    eff = get_effect('fast_dynamics')
    assert eff.own_grid
    for tau in (0.8, 2.0, 6.0):
        lo, hi, start = eff.scratch_bounds(act.ActuatorParams().with_changes(
            heat_capacity_j_per_k=tau * act.ActuatorParams().conductance_w_per_k))['tau_s']
        assert lo == pytest.approx(0.5 * tau) and start == pytest.approx(tau) and hi >= 20.0


def test_phase_resistance_scratch_start_is_a_strong_effect_of_the_drives_sign():
    eff = get_effect('phase_resistance')
    for params in (act.ActuatorParams(), act.ActuatorParams(current_limit_a=5.0)):
        lo, hi, _ = eff.bounds(params)['phase_kappa']
        k = eff.scratch_start(params)['phase_kappa']
        assert lo <= k <= hi and abs(k) >= 0.5 * max(abs(lo), abs(hi))


@pytest.mark.slow
def test_feedback_weights_are_settled_to_their_fixed_point():
    # heating depends on the wire's own contraction (phase resistance), so the regression
    # sees the hysteresis through a reference model; settled, the fit at the true kappa and
    # time constant reproduces the data, while one regression through a zero-weight
    # reference (no feedback seen) leaves a clear error
    true = act.ActuatorParams(phase_kappa=0.3)
    data = record(true, seconds=180.0, noise=0.001)
    n = int(0.7 * len(data))
    fixed = {'phase_kappa': (0.2999, 0.3, 0.3), 'tau_s': (1.9999, 2.0, 2.0)}
    fit = idn.fit_dynamic(data, free=fixed)
    values = {'phase_kappa': 0.3, 'tau_s': 2.0}
    setup = idn.Setup(data, act.ActuatorParams(ambient_gain=0.0), fixed, values, n, 40)
    prob = idn._Problem(setup, fit.grid)
    nonlinear = idn.set_values(prob.base, values)
    once = prob.with_linear(nonlinear, prob.solve(nonlinear))
    err_once = np.sqrt(np.mean(prob.free_run_error(once, {}) ** 2))
    err_settled = np.sqrt(idn._settle(prob, values, fit.grid).mse)
    print(f'feedback fixed point: RMS {err_once:.4f} rad once, {err_settled:.4f} rad settled')
    assert err_settled < 0.5 * err_once
    assert err_settled < 0.004 and fit.train['rmse'] < 0.004       # noise 1 mrad, 2 rad travel


@pytest.mark.slow
def test_candidates_refitted_on_two_cores_equal_one_core_and_plugins_stay_local():
    rng = np.random.default_rng(4)
    n = int(150 / DT)
    da, db = multilevel_duty(n, DT, rng)
    heat = [np.clip((d - 0.2) / 0.8, 0, 1) for d in (da, db)]
    y = act.simulate(act.ActuatorParams(delay_s=0.2), heat[0], heat[1], DT).position_rad
    data = idn.DynamicData(np.arange(n) * DT, da, db, y + rng.normal(0, 0.002, n))
    base = engine.fit_model(data, ())
    register_effect(DeadTime)          # registered here only: a worker process lacks it
    try:
        names = ['delay', 'convection', 'test_dead_time']
        one = diagnosis.diagnose(data, base=base, candidates=names, jobs=1)
        two = diagnosis.diagnose(data, base=base, candidates=names, jobs=2)
    finally:
        CATALOG.pop('test_dead_time', None)
    assert [c['effect'] for c in one.candidates] == [c['effect'] for c in two.candidates]
    for a, b in zip(one.candidates, two.candidates):
        assert a['validation_nrmse'] is not None
        assert b['validation_nrmse'] == pytest.approx(a['validation_nrmse'], rel=1e-6)
        assert a['significant'] == b['significant']
    assert one.missing_effect == two.missing_effect


def test_a_delay_below_one_sample_period_is_not_resolved():
    data = record(act.ActuatorParams(), seconds=20.0)
    eff = get_effect('delay')
    assert 'below one sample period' in eff.unresolved({'delay_s': 0.6 * DT}, data)
    assert eff.unresolved({'delay_s': 2.0 * DT}, data) is None
    assert get_effect('convection').unresolved({'convection_exponent': 1e-6}, data) is None


def test_a_lag_below_half_a_sample_period_is_not_resolved():
    # below half a sample period a lag is a sub-sample shift, as a delay below one sample is
    data = record(act.ActuatorParams(), seconds=20.0)
    eff = get_effect('fast_dynamics')
    assert 'below half a sample period' in eff.unresolved({'tau_fast_s': 0.4 * DT}, data)
    assert eff.unresolved({'tau_fast_s': 0.6 * DT}, data) is None
