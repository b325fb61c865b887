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
Judge one candidate effect: refit the base model with it and test what it gains.

For every candidate effect not in the model, `judge_candidate` refits with it (same
hysteresis grid, warm-started from the base fit, so candidates compete on equal terms) and
scores the held-out error. A candidate is significant only if
  1. held-out NRMSE falls by at least `min_improvement` (default 20 %),
  2. the Bayesian information criterion of the free-run residual on the training window
     agrees: BIC = n_eff ln(RSS / n) + k ln(n_eff) falls by more than `BIC_MARGIN` (10,
     "very strong" evidence), with n_eff the number of
     effectively independent samples (n divided by the residual's correlation length, the
     shorter of the base's and the candidate's), so serially correlated residuals cannot
     buy extra parameters cheaply; the candidate nests the base model, so a missing effect
     must fit the training window better by more than its extra parameters' worth (a
     held-out gain without that is luck of the split, not physics), and
  3. the effect itself carries the gain (the counterfactual): the base model refitted
     from where the candidate's refit ended (its hysteresis grid, weights and time
     constant) with the effect off must be worse on held-out data by at least
     `min_improvement` again; otherwise the gain came from the new grid or a re-tuned
     base (a fragile held-out window), not from the effect; and the training window must
     say so too: BIC against that refit must fall by more than `BIC_MARGIN` as in 2 (a
     new grid lets the free weights absorb a static distortion, so a sensor polynomial
     can fit training no better than the regridded base and still bend one held-out
     transient its way); and the gain must not come from a minority of the held-out
     motion only: where at least `MIN_MOVING_BLOCKS` of the `HELD_OUT_BLOCKS` blocks of
     held-out time each move over `MIN_COVERAGE` of the measured range, the median gain
     over those blocks (`moving_block_gains`) must not be below zero (a refit that moves
     the base's own parameters along a flat training valley can win a few blocks and lose
     the rest; a block that hardly moves is at the noise in both, its sign chance), and
  4. the fitted effect is large enough for the data to resolve (`Effect.unresolved`; a
     delay must exceed one sample period), and an effect on the heating law
     (`Effect.heating_law`) is not judged on training records that heat at one duty level
     (`levels.duty_levels`): there it fits about as well as any other heating law.
"""
from dataclasses import fields
import time
from typing import Any, Optional, Tuple

import numpy as np

from .branches import extrapolated_error_share, extrapolated_share, MOSTLY_EXTRAPOLATED
from .effects import CATALOG, Effect, get_effect
from .engine import (fit_model, MIN_COVERAGE, ModelFit, noise_floor, prefer_warm,
                     REFIT_SEARCH)
from .levels import duty_levels
from ..core import actuator as act
from ..core.datakinds import DynamicData, Split
from ..core.scoring import NEAR_NOISE

MIN_IMPROVEMENT = 0.20
# BIC must fall by at least this much: "very strong" evidence on Kass & Raftery's (1995)
# scale; smaller falls come from training fits that hardly changed
BIC_MARGIN = 10.0
# blocks of equal time the held-out window is cut into for the typical gain (`typical_gain`)
HELD_OUT_BLOCKS = 5
# fewest moving held-out blocks whose median gain must not be negative (check 3): a
# majority of the blocks
MIN_MOVING_BLOCKS = 3


def correlation_length(residual: np.ndarray) -> int:
    """Lag (samples) where the residual's autocorrelation first drops below 1/e (>= 1)."""
    r = np.asarray(residual, float) - np.mean(residual)
    if len(r) < 4 or not np.any(r):
        return 1
    f = np.fft.rfft(r, 2 * len(r))
    acf = np.fft.irfft(f * np.conj(f))[: len(r)]
    acf /= acf[0]
    below = np.flatnonzero(acf < np.exp(-1))
    return int(below[0]) if below.size else len(r)


def bic(residual: np.ndarray, n_parameters: int, n_eff: float) -> float:
    """BIC = n_eff ln(RSS/n) + k ln(n_eff) of a residual with k parameters."""
    r = np.asarray(residual, float)
    return n_eff * np.log(np.mean(r ** 2) + 1e-300) + n_parameters * np.log(max(n_eff, 2))


def bic_gain(base: ModelFit, fit: ModelFit, base_length: Optional[int] = None) -> float:
    """
    Return BIC(fit) − BIC(base) on their training residuals (negative: `fit` is better).

    Both are counted on n_eff = n / L effectively independent samples, L the shorter
    correlation length of the two residuals (`base_length`: the base's, if known). A slow
    effect the base lacks stretches the base residual's correlation over the whole record
    (a drift: 16 750 samples at 1694 samples of correlation count as 9.9), while the
    residual of the model with the effect shows the noise's own correlation (2 samples).
    """
    length = min(base_length or correlation_length(base.residual),
                 correlation_length(fit.residual))
    n_eff = max(len(base.residual) / length, 2.0)
    return (bic(fit.residual, _free_count(fit), n_eff)
            - bic(base.residual, _free_count(base), n_eff))


def _free_count(fit: ModelFit) -> int:
    """Return the effects' parameter count; an effect that sets the PI kind counts one."""
    return sum(len(get_effect(e).parameters) + (1 if get_effect(e).kind else 0)
               for e in fit.effects)


def held_out_block_rmse(data: DynamicData, reference: ModelFit,
                        fit: ModelFit) -> Optional[np.ndarray]:
    """
    Return the RMSE [output unit] of `reference` (row 0) and `fit` (row 1) in each block.

    The held-out samples (of the reference's split) are cut into `HELD_OUT_BLOCKS` blocks of
    equal count; column j holds √(mean((ŷ − y)²)) over block j. None when there are fewer
    held-out samples than blocks or a prediction is missing.
    """
    if reference.split is None or reference.prediction is None or fit.prediction is None:
        return None
    blocks = held_out_blocks(data, reference.split)
    if len(blocks[-1]) == 0:
        return None
    y = data.output
    return np.array([[np.sqrt(np.mean((model.prediction[block] - y[block]) ** 2))
                      for block in blocks]
                     for model in (reference, fit)])


def held_out_blocks(data: DynamicData, split: Split) -> list:
    """Return the sample indices of `split`'s held-out window in `HELD_OUT_BLOCKS` blocks."""
    _, val = data.split_masks(split)
    return np.array_split(np.flatnonzero(val), HELD_OUT_BLOCKS)


def typical_gain(data: DynamicData, reference: ModelFit, fit: ModelFit) -> Optional[float]:
    """
    Return the median over held-out time blocks of 1 − RMSE(fit) / RMSE(reference).

    The blocks are those of `held_out_block_rmse`. The median says how much better `fit`
    is for most of the held-out time: one excursion beyond the travel training saw can
    carry the whole window's RMSE, and after it the hysteresis state of every model stays
    off for a while. None when there are no blocks or a block's reference error is 0.
    """
    rmse = held_out_block_rmse(data, reference, fit)
    if rmse is None or np.any(rmse[0] <= 0):
        return None
    return float(np.median(1.0 - rmse[1] / rmse[0]))


def moving_block_gains(data: DynamicData, reference: ModelFit,
                       fit: ModelFit) -> Optional[np.ndarray]:
    """
    Return 1 − RMSE(fit) / RMSE(reference) in each held-out block that moves.

    The blocks are those of `held_out_block_rmse`; a block moves when the measured output
    in it covers at least `MIN_COVERAGE` of the range measured over the whole set
    (`data.span()`, the NRMSE's scale), as a validation window must to be informative.
    None when there are no blocks or a moving block's reference error is 0.
    """
    rmse = held_out_block_rmse(data, reference, fit)
    if rmse is None:
        return None
    moving = np.array([np.ptp(data.output[b]) >= MIN_COVERAGE * data.span()
                       for b in held_out_blocks(data, reference.split)])
    if np.any(rmse[0][moving] <= 0):
        return None
    return 1.0 - rmse[1][moving] / rmse[0][moving]


def few_moving_stretches(data: Any, reference: ModelFit,
                         fit: ModelFit) -> Optional[np.ndarray]:
    """
    Return the moving blocks' gains when a few stretches carry `fit`'s gain, else None.

    Check 3's last part: where at least `MIN_MOVING_BLOCKS` held-out blocks move
    (`moving_block_gains`), their median gain over `reference` must not be below zero.
    """
    moving = (moving_block_gains(data, reference, fit)
              if isinstance(data, DynamicData) else None)
    if moving is None or len(moving) < MIN_MOVING_BLOCKS or np.median(moving) >= 0.0:
        return None
    return moving


def candidate_tasks(data: Any, base: ModelFit, candidates: Optional[list] = None,
                    min_improvement: float = MIN_IMPROVEMENT) -> list:
    """
    One `judge_candidate` task per candidate effect not already in `base`.

    A task is (data, base, name, base_length, min_improvement): base_length is the
    correlation length (samples) of the base's training residual, computed once here.
    """
    names = [n for n in (candidates or CATALOG) if n not in base.effects]
    base_length = correlation_length(base.residual)
    return [(data, base, name, base_length, min_improvement) for name in names]


def judge_candidate(task: tuple) -> dict:
    """
    Refit with one candidate effect and judge it (see the module docstring).

    Returns the candidate's entry of `Diagnosis.candidates` (module level: runs in worker
    processes).
    """
    started = time.perf_counter()
    entry = _judge(*task)
    entry['seconds'] = time.perf_counter() - started
    return entry


def _judge(data: Any, base: ModelFit, name: str, base_length: int,
           min_improvement: float, warm: Optional[ModelFit] = None) -> dict:
    """
    Return the candidate entry of `name` (without its time).

    warm: its refit warm from the base, already made; then it is also refitted from
    scratch and one of the two is judged (`prefer_warm`).
    """
    eff = get_effect(name)
    reason = data.unsupported(eff)
    if reason is None and eff.kind is not None and base.kind == eff.kind:
        reason = f'the base model already is {eff.kind} PI'
    if reason:
        entry = {'effect': name, 'validation_nrmse': None, 'train_nrmse': None,
                 'improvement': None, 'significant': False,
                 'explanation': f'not applicable: {reason}'}
        lacking = eff.applicable(data)
        if lacking:
            entry['data_lack'] = lacking     # a signal or records the user could add
        return entry
    effects = list(base.effects) + [name]
    try:
        fit = fit_model(data, effects, kind=base.kind, base_fit=base if warm is None else None,
                        search=REFIT_SEARCH)
        if warm is not None and prefer_warm(data, warm, fit):
            fit = warm
    except ValueError as err:
        return {'effect': name, 'validation_nrmse': None, 'train_nrmse': None,
                'improvement': None, 'significant': False,
                'explanation': f'fit failed: {err}'}
    v0, v1 = base.validation['nrmse'], fit.validation['nrmse']
    gain = (v0 - v1) / v0 if v0 > 0 else 0.0
    bic_change = bic_gain(base, fit, base_length)
    evident = gain >= min_improvement and bic_change < -BIC_MARGIN
    # the counterfactual costs a fit, so it runs only where the first two checks pass
    base_refit = regridded_base(data, base, fit, eff) if evident else None
    v_off = None if base_refit is None else base_refit.validation['nrmse']
    # the base refitted where the candidate's refit ended, without the effect, must fall
    # short of it by at least the improvement asked of the effect, held out and in training
    carried = v_off is None or v_off <= 0 or (v_off - v1) / v_off >= min_improvement
    bic_off = None if base_refit is None else bic_gain(base_refit, fit)
    carried = carried and (bic_off is None or bic_off < -BIC_MARGIN)
    few = few_moving_stretches(data, base, fit) if evident and carried else None
    spread = few is None
    unresolved = unresolved_by(eff, fit.values, data, base)
    significant = bool(evident and carried and spread and unresolved is None)
    checks = ('' if v_off is None else
              f", {100 * v_off:.2f} % for the base refitted on the candidate's grid"
              f' (training NRMSE {100 * base_refit.train["nrmse"]:.2f} %, BIC change '
              f'{bic_off:+.1f} against it)')
    if warm is not None and fit is not warm:
        checks += (', refitted from scratch (the warm refit fitted the training window worse)'
                   if fit.train['rmse'] < warm.train['rmse'] else
                   ', refitted from scratch (it fits the training window to the noise; the '
                   'warm refit only fits the noise better)')
    if evident and not carried:
        checks += ('; not significant: the base refitted on the same grid does about as '
                   'well, so the grid, not the effect, carries the gain')
    if not spread:
        checks += (f'; not significant: {np.sum(few < 0)} of the {len(few)} held-out '
                   f'blocks that move get worse (median {100 * np.median(few):+.1f} %), '
                   'so a few stretches, not the effect, carry the gain')
    if unresolved:
        checks += f'; not significant: {unresolved[0]}'
    unit = getattr(data, 'position_unit', '')
    values = ', '.join(f'{act.name_in_unit(k, unit)} = {v:.4g}' for k, v in fit.values.items()
                       if k in eff.parameters) or 'modified PI (saturated plays)'
    return {'effect': name, 'validation_nrmse': v1, 'train_nrmse': fit.train['nrmse'],
            'improvement': gain, 'significant': significant,
            # the only check it failed: a rival to whatever is named instead
            'unresolved': unresolved if evident and carried and spread else None,
            'explanation': (f'held-out NRMSE {100 * v0:.2f} % -> {100 * v1:.2f} % '
                            f'({100 * gain:+.0f} % better), training NRMSE '
                            f'{100 * base.train["nrmse"]:.2f} % -> '
                            f'{100 * fit.train["nrmse"]:.2f} %, '
                            f'BIC change {bic_change:+.1f}{checks}; '
                            f'fitted {values}. Signature: {eff.signature}.'),
            'fit': fit, 'bic_change': float(bic_change), 'base_refit': base_refit}


def unresolved_by(eff: Effect, values: dict, data: Any,
                  base: Optional[ModelFit] = None) -> Optional[tuple]:
    """
    Return (why `data` cannot resolve the fitted effect, what would tell it apart), or None.

    Check 4: the effect's own resolution at the fitted `values` (`Effect.unresolved`: a
    delay or lag shorter than the sample period allows), a held-out window that only
    extrapolates from the `base` fit (`beyond_training`), and for an effect on the heating
    law (`Effect.heating_law`) training records that heat at one duty level
    (`levels.duty_levels`, on the fit's training window), where any heating law fits.
    """
    reason = eff.unresolved(values, data)
    if reason:
        return reason, 'at this sample rate the two are not told apart; record faster'
    beyond = None if base is None else beyond_training(data, base)
    if beyond is not None:
        share, error = beyond
        of_error = '' if error is None else f" ({100 * error:.0f} % of the base's error over it)"
        return (f'{100 * share:.0f} % of the held-out window{of_error} lies on branches of the '
                'loop beyond the positions the training window reached on them, and the base '
                "fits the training window to the noise: the gain is an extrapolation's",
                'hold out a record that the training records cover (two or more records, or '
                '--validate-on)')
    if not eff.heating_law or getattr(data, 'kind', None) != DynamicData.kind:
        return None
    levels = duty_levels(data, data.default_split())
    if levels is None or not levels.one_level:
        return None
    return (f'the training records heat at one duty level ({100 * levels.share:.0f} % of the '
            f'heated time at duty {levels.level:.3g}), where a heating law is not identified',
            'records at one duty level do not tell the two apart; record other duty levels')


def beyond_training(data: Any, base: ModelFit) -> Optional[Tuple[float, Optional[float]]]:
    """
    Return (held-out share, base error share) beyond the trained branches, where they rule.

    Over `MOSTLY_EXTRAPOLATED` of one record's held-out window, or of the base's squared
    error over it, lies beyond the positions its training window reached on each branch of
    the loop (`branches.extrapolated_share`, `extrapolated_error_share`) while the base fits
    the training window to within `NEAR_NOISE` of the noise floor (`noise_floor`): nothing
    in training shows an effect, and a held-out gain, won mostly where the base
    extrapolates, says which extrapolation fits. None otherwise; the error share is None
    when the base has no prediction or predicts the held-out window exactly.
    """
    share = extrapolated_share(data)
    if share is None:
        return None
    prediction = getattr(base, 'prediction', None)
    error = None if prediction is None else extrapolated_error_share(data, prediction)
    if max(share, error or 0.0) <= MOSTLY_EXTRAPOLATED:
        return None
    floor = noise_floor(data)
    return (share, error) if floor and base.train['nrmse'] <= NEAR_NOISE * floor else None


def regridded_base(data: DynamicData, base: ModelFit, fit: ModelFit,
                   eff: Effect) -> Optional[ModelFit]:
    """
    Return the base model refitted from where the candidate's refit ended.

    The counterfactual of the candidate's gain: the base's own parameters (time constant,
    weights) refitted on the candidate's hysteresis grid, warm from its values, with the
    effect off. When that does as well, the gain came from the new grid or a re-tuned
    base, not from the effect. None when it does not apply (static data, no parameters).
    """
    if not eff.parameters or fit.split is None or fit.split.start is None:
        return None
    names = {f.name for f in fields(act.ActuatorParams)}
    neutral = {k: getattr(base.params, k) for k in eff.parameters if k in names}
    start = {k: v for k, v in fit.values.items() if k not in eff.parameters}
    off = ModelFit(list(base.effects), base.kind, start, None, None, None, None, 0, None,
                   fit.params.with_changes(**neutral), grid=fit.grid)
    return fit_model(data, list(base.effects), kind=base.kind, base_fit=off)
