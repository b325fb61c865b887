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
Diagnose the missing effect: judge every candidate (`judging`), rank them, name the first.

A candidate that passes checks 1-3 of `judging` but not 4 (too small for the data to
resolve, or a heating law on records at one duty level) and gains more held out than a
significant one, beyond `NEAR_TIE`, makes that one not significant too: the records cannot
tell which of the two they show (`_yield_to_unresolved_rivals`).

When no candidate is significant, every one without an own grid is also refitted from
scratch and judged again: with two effects missing, the base can sit so far from the data
that a warm refit stays in its basin. The fit from scratch is judged where it trains to
within `NEAR_NOISE` times the noise, as `fit_dynamic` stops there, else the better training
fit of the two (`engine.prefer_warm`): at the noise the warm refit, on the base grid, can
train better by fitting noise with that grid's extra elements, and its better training does
not say it holds out better. In the first pass, an own-grid candidate's best warm trial and
its best trial from scratch are chosen between by the same rule, except that a warm trial
training clearly better (by `NEAR_TIE`) stands (`engine.warm_trial_stands`). A base that
already fits its training window to within the noise (`at_noise`) has no such basin: the
second pass is skipped. And when a counterfactual (check 3) is itself a better fit of the
base model, by `min_improvement` in training RMSE and no worse held out (and, when an
effect is named, better held out than the named effect's model by `min_improvement`, or
better than it in training by that bar and no worse held out), the base's own fit sat in a
poor minimum: the diagnosis starts again from that fit (`better_base`, `Diagnosis.refitted`
says so). Where the named effect's model beats that fit, diagnose runs again from it all the
same, and an effect named there whose model outfits the named one's (`outfits_named`)
stands instead (`second_opinion`): against a base in a poor minimum a candidate whose refit
leaves that minimum gains, and one whose refit stays in it does not. When still nothing is
named and the base is short of the noise, check 1 is taken once more on the typical
held-out gain (`typical_pass`): the median over `HELD_OUT_BLOCKS`
blocks of held-out time, against the base and against the counterfactual. One excursion
beyond the trained travel can carry the whole window's RMSE while the candidate is better
everywhere else; checks 2 and 4 stay as they are, and so does the moving blocks' median of
check 3. Candidates are listed best first: significant ones by held-out improvement, then
the rest by held-out improvement; the first significant one is the missing effect. Two
significant candidates that retard the response (a delay and a lag,
`Effect.retards_response`) are ranked by their training BIC instead, where one fits the
training window clearly better (by `NEAR_TIE` in NRMSE; `_rank_retarders_by_training`): the
held-out window tells a dead time from a lag by chance where the base misfits it. When
several significant candidates come within `NEAR_TIE` (10 %) of the best gain, the data can
hardly tell them apart: they stay in held-out order and every explanation in the group says
so. When nothing is named because the base already predicts the held-out window to the
noise while its training window is misfitted, the candidate that fits training best is
reported as a lead to test elsewhere, not a name (`training_lead`).
"""
from dataclasses import dataclass
from functools import partial
from itertools import chain
from typing import Any, Callable, Iterator, Optional

import numpy as np

from .effects import CATALOG, get_effect, is_builtin
from .engine import fit_model, held_out_cannot_judge, ModelFit, NEAR_TIE, noise_floor
from .judging import (bic_gain, BIC_MARGIN, candidate_tasks, few_moving_stretches,
                      HELD_OUT_BLOCKS, judge_candidate, MIN_IMPROVEMENT, regridded_base,
                      typical_gain, unresolved_by)
from .parallel import available_cores, imap_on_cores
from ..core.datakinds import DynamicData
from ..core.scoring import NEAR_NOISE

# candidate entry keys kept out of `Diagnosis.to_json` (objects, timings, internal checks)
INTERNAL_KEYS = ('fit', 'bic_change', 'seconds', 'base_refit', 'unresolved')


@dataclass
class Diagnosis:
    """Result of `diagnose`."""

    baseline: ModelFit
    candidates: list
    missing_effect: object
    # why the baseline is not the model diagnose was given: a better fit of it was found
    refitted: str = ''
    # seconds of candidate refits not listed: judged against the base before it was
    # refitted, or from a better base whose diagnosis did not stand (`second_opinion`)
    earlier_seconds: float = 0.0
    # the NRMSE the measurement noise alone gives (`noise_floor`), None if not known
    noise_floor_nrmse: Optional[float] = None
    # what fits a training window the held-out one cannot judge (`training_lead`), or None
    training_lead: Optional[dict] = None

    def to_json(self) -> dict:
        """Return the `sma-model diagnose --json` document."""
        base = {'effects': list(self.baseline.effects),
                'validation_nrmse': self.baseline.validation['nrmse'],
                'train_nrmse': self.baseline.train['nrmse']}
        if self.noise_floor_nrmse is not None:
            base['noise_floor_nrmse'] = self.noise_floor_nrmse
        if self.refitted:
            base['refitted'] = self.refitted
        doc = {'baseline': base,
               'candidates': [candidate_json(c) for c in self.candidates],
               'missing_effect': self.missing_effect}
        if self.training_lead:
            doc['training_lead'] = self.training_lead
        return doc


def candidate_json(entry: dict) -> dict:
    """Return a candidate entry's JSON form: 'not_resolved' says why check 4 refused it."""
    out = {k: v for k, v in entry.items() if k not in INTERNAL_KEYS}
    if entry.get('unresolved'):
        out['not_resolved'] = entry['unresolved'][0]
    return out


def diagnose(data: Any, base: Optional[ModelFit] = None, candidates: Optional[list] = None,
             progress: Optional[Callable] = None, min_improvement: float = MIN_IMPROVEMENT,
             kind: Optional[str] = None, jobs: int = 1,
             mapper: Optional[Callable] = None, rebase: int = 1) -> 'Diagnosis':
    """
    Rank candidate effects by held-out error reduction; name the missing one (or None).

    base: a ModelFit (or None: fit the paper's base model, `kind` PI). candidates: effect
    names (default: every catalog effect not in the base). jobs: processes for the
    candidate refits (independent fits; 0 = every core). mapper(tasks) -> the
    `judge_candidate` entries of the tasks, in any order: runs the refits elsewhere (the
    batch sends them to its Dask cluster); default: a pool of `jobs` processes. Plug-in
    effects are refitted in this process, since a worker would not have them registered.
    rebase: how many times a better fit of the base itself, found by a counterfactual
    (`better_base`), may replace it and the diagnosis start again from there, or, where
    the named effect's model beats that fit, the diagnosis be run again from it as a
    second opinion (`second_opinion`).
    """
    if base is None:
        base = fit_model(data, (), kind=kind)
    tasks = candidate_tasks(data, base, candidates, min_improvement)
    names = [t[2] for t in tasks]
    builtin = all(is_builtin(e) for e in base.effects)

    def poolable(name: str) -> bool:
        """Return True for a costly refit (worth a process) of an effect every process has."""
        return (builtin and is_builtin(name) and data.costly_fit
                and data.unsupported(get_effect(name)) is None)

    def judged(tasks: list, stage: str) -> dict:
        """Return {name: entry} of `tasks`, the costly ones on the pool or `mapper`."""
        pooled, local = [], []
        for t in tasks:
            (pooled if poolable(t[2]) else local).append(t)
        # the slowest refits (a second one from scratch) first, so no core idles at the end
        pooled.sort(key=lambda t: not get_effect(t[2]).own_grid)
        out = {}
        if progress:
            progress(0, len(tasks), stage)
        for entry in chain(map(judge_candidate, local),
                           (mapper or partial(_judge_on_cores, jobs))(pooled)):
            out[entry['effect']] = entry
            if progress:
                progress(len(out), len(tasks), entry['effect'])
        return out

    entries = judged(tasks, 'candidates')
    diag = rank_candidates(base, list(entries.values()))
    # nothing named: a base far from the data (another effect missing too) can hold a warm
    # refit in its basin, so each candidate is also refitted from scratch and judged again
    if (diag.missing_effect is None and isinstance(data, DynamicData)
            and not at_noise(base, data, min_improvement)):
        rescue = [t + (entries[t[2]]['fit'],) for t in tasks
                  if 'fit' in entries[t[2]] and not get_effect(t[2]).own_grid]
        if rescue:
            entries.update(judged(rescue, 'candidates from scratch'))
            diag = rank_candidates(base, list(entries.values()))
    if (diag.missing_effect is None and isinstance(data, DynamicData)
            and not at_noise(base, data, min_improvement)):
        named = typical_pass(data, base, list(entries.values()), min_improvement)
        if named:
            diag = rank_candidates(base, list(entries.values()), 'typical_gain')
    better = (better_base(base, list(entries.values()), min_improvement,
                          named=entries.get(diag.missing_effect))
              if rebase > 0 else None)
    if better is not None:
        refit, why = better
        diag = diagnose(data, refit, candidates, progress, min_improvement, kind, jobs, mapper,
                        rebase - 1)
        diag.refitted = '; '.join(filter(None, (why, diag.refitted)))
        diag.earlier_seconds += sum(c.get('seconds', 0.0) for c in entries.values())
    elif rebase > 0 and diag.missing_effect is not None and len(names) > 1:
        # with one candidate the better base can name no other effect
        diag = second_opinion(diag, entries, min_improvement, partial(
            diagnose, data, candidates=candidates, progress=progress,
            min_improvement=min_improvement, kind=kind, jobs=jobs, mapper=mapper,
            rebase=rebase - 1))
    diag.noise_floor_nrmse = noise_floor(data)
    diag.training_lead = training_lead(data, diag, min_improvement)
    if progress:
        progress(len(names), len(names), 'done')
    return diag


def at_noise(base: ModelFit, data: DynamicData, min_improvement: float) -> bool:
    """
    Return True when the base fits its training window to within the measurement noise.

    True when training NRMSE <= noise floor / (1 − min_improvement): no refit, from
    anywhere, can fit that window by `min_improvement` better without fitting the noise,
    so there is no basin for a refit from scratch to escape.
    """
    floor = noise_floor(data)
    return floor is not None and bool(base.train['nrmse'] * (1.0 - min_improvement) <= floor)


def training_lead(data: Any, diag: 'Diagnosis', min_improvement: float) -> Optional[dict]:
    """
    Return the candidate that best fits a training window the held-out one cannot judge.

    When nothing is named, the base predicts the held-out window to within `NEAR_NOISE`
    times the noise floor (`Diagnosis.noise_floor_nrmse`) and fits its training window
    worse than `TRAINING_MISFIT` times it, no candidate can gain held out (check 1), yet
    the training window shows something missing. The lead is, of the resolved candidates
    (check 4) whose refit fits the training window by `min_improvement` better in NRMSE,
    beats the base on BIC by `BIC_MARGIN` (check 2) and still holds out within
    `NEAR_NOISE` of the noise, the one with the largest BIC fall: a hint to test on a
    record that shows it, not a name. data: the records diagnosed (for check 4). Returns
    {'effect', 'train_nrmse', 'validation_nrmse', 'bic_change'} or None.
    """
    base, floor = diag.baseline, diag.noise_floor_nrmse
    if (diag.missing_effect is not None or not floor or base.validation is None
            or not held_out_cannot_judge(base.validation['nrmse'] / floor,
                                         base.train['nrmse'] / floor)):
        return None
    leads = [c for c in diag.candidates if 'fit' in c
             and c['bic_change'] < -BIC_MARGIN
             and c['fit'].train['nrmse'] <= (1.0 - min_improvement) * base.train['nrmse']
             and c['fit'].validation['nrmse'] <= NEAR_NOISE * floor
             and unresolved_by(get_effect(c['effect']), c['fit'].values, data, base) is None]
    if not leads:
        return None
    best = min(leads, key=lambda c: c['bic_change'])
    return {'effect': best['effect'], 'train_nrmse': best['fit'].train['nrmse'],
            'validation_nrmse': best['fit'].validation['nrmse'],
            'bic_change': best['bic_change']}


def typical_pass(data: DynamicData, base: ModelFit, entries: list,
                 min_improvement: float) -> list:
    """
    Judge entries again on their typical held-out gain; return the names made significant.

    A candidate whose refit passes the BIC check (2) and is resolved (4) is significant
    when its typical gain (`typical_gain`) over the base is at least `min_improvement`, and
    so is its typical gain over the counterfactual (3: the base refitted on its grid without
    it), whose training fit it beats on BIC as in 3, and a few moving stretches do not
    carry it (`few_moving_stretches`, as in 3: blocks that hardly move can lift the median
    of all five). Each such entry gets 'typical_gain' and says so in its explanation.
    """
    named = []
    for c in entries:
        fit = c.get('fit')
        if (fit is None or c['significant'] or c.get('rival')
                or c['bic_change'] >= -BIC_MARGIN):
            continue
        eff = get_effect(c['effect'])
        gain = typical_gain(data, base, fit)
        if (gain is None or gain < min_improvement or unresolved_by(eff, fit.values, data, base)
                or few_moving_stretches(data, base, fit) is not None):
            continue
        off = c.get('base_refit') or regridded_base(data, base, fit, eff)
        carried = None if off is None else typical_gain(data, off, fit)
        if off is not None and (carried is None or carried < min_improvement
                                or bic_gain(off, fit) >= -BIC_MARGIN):
            continue
        c.update(significant=True, typical_gain=gain)
        c['explanation'] += (
            f' Significant by its typical held-out gain: the median over {HELD_OUT_BLOCKS} '
            f'blocks of held-out time is {100 * gain:+.0f} % against the base'
            + ('' if carried is None else
               f' and {100 * carried:+.0f} % against the base refitted on its grid')
            + f' (whole window {100 * c["improvement"]:+.0f} %).')
        named.append(c['effect'])
    return named


def better_base(base: ModelFit, entries: list, min_improvement: float,
                named: Optional[dict] = None) -> Optional[tuple]:
    """
    Return (a better fit of the base model, why) from the candidates' counterfactuals, or None.

    A counterfactual refits the base model itself (no effect added) from where a
    candidate's refit ended. When that fits the training window better by at least
    `min_improvement` (training RMSE, the fit's own objective) and is no worse held out, the
    base's own fit sat in a poor minimum: with two effects missing, a fit that lacks both can
    end far from its best. Candidates judged against such a base are judged against the
    wrong reference, so diagnose starts again from the better fit. named: the entry of the
    effect named against the base; it has beaten its own counterfactual, so the better fit
    must also beat it held out by `min_improvement`, the bar the effect cleared to be named
    (the base without any effect predicting clearly better than the named effect: the gain
    was the base's poor minimum, not the effect; near the noise floor a smaller held-out
    difference is chance), or else fit training better than the effect's model by that bar
    and hold out no worse (`outfits_named`).
    """
    found = better_base_fit(base, entries, min_improvement)
    if found is None:
        return None
    refit, why = found
    if named is not None and not (refit.validation['nrmse'] < (1.0 - min_improvement) * named.get(
            'validation_nrmse', -np.inf) or outfits_named(refit, named, min_improvement)):
        return None
    return refit, why + ': diagnosed from that fit'


def better_base_fit(base: ModelFit, entries: list, min_improvement: float) -> Optional[tuple]:
    """
    Return (the counterfactual that fits the base model best, why) where it beats `base`.

    Of the entries' counterfactuals (the base model refitted from where a candidate's refit
    ended), the one of least training RMSE, where that is below (1 − min_improvement) times
    the base's and its held-out NRMSE is no worse than the base's; else None.
    """
    refits = [(c['base_refit'], c['effect']) for c in entries if c.get('base_refit') is not None]
    if not refits:
        return None
    refit, name = min(refits, key=lambda r: r[0].train['rmse'])
    t0, t1 = base.train['rmse'], refit.train['rmse']
    v0, v1 = base.validation['nrmse'], refit.validation['nrmse']
    if t1 > (1.0 - min_improvement) * t0 or v1 > v0:
        return None
    return refit, (f'the base model refitted from where the {name} refit ended fits better '
                   f'(training NRMSE {100 * base.train["nrmse"]:.2f} % -> '
                   f'{100 * refit.train["nrmse"]:.2f} %, held-out {100 * v0:.2f} % -> '
                   f'{100 * v1:.2f} %)')


def second_opinion(diag: 'Diagnosis', entries: dict, min_improvement: float,
                   rediagnose: Callable) -> 'Diagnosis':
    """
    Return the diagnosis from a better base fit the named effect kept its name against.

    Where `better_base_fit` finds a better fit of the base and the named effect's model still
    beats it (`better_base` keeps the base), the candidates were judged against a base in a
    poor minimum: a candidate whose refit leaves it gains, one whose refit stays in it does
    not, whichever is the missing effect. So diagnose runs again from the better fit
    (rediagnose(base) -> Diagnosis). When it names another effect whose model outfits the
    named one's (`outfits_named`: training RMSE lower by `min_improvement`, held out no
    worse), its diagnosis stands; else `diag`. entries: {name: entry} judged against the
    base of `diag`.
    """
    found = better_base_fit(diag.baseline, list(entries.values()), min_improvement)
    if found is None:
        return diag
    refit, why = found
    other = rediagnose(refit)
    named = entries[diag.missing_effect]
    theirs = next((c for c in other.candidates if c['effect'] == other.missing_effect), None)
    spent = sum(c.get('seconds', 0.0) for c in other.candidates) + other.earlier_seconds
    if (theirs is None or theirs['effect'] == named['effect']
            or not outfits_named(theirs['fit'], named, min_improvement)):
        diag.earlier_seconds += spent
        return diag
    other.refitted = '; '.join(filter(None, (
        f'{why}: diagnosed from that fit, {theirs["effect"]} outfits {named["effect"]} named '
        f'against the base (training NRMSE {100 * theirs["fit"].train["nrmse"]:.2f} % '
        f'against {100 * named["fit"].train["nrmse"]:.2f} %, held-out '
        f'{100 * theirs["validation_nrmse"]:.2f} % against '
        f'{100 * named["validation_nrmse"]:.2f} %)', other.refitted)))
    other.earlier_seconds += sum(c.get('seconds', 0.0) for c in entries.values())
    return other


def outfits_named(refit: ModelFit, named: dict, min_improvement: float) -> bool:
    """
    Return whether a fit of the base beats the named effect's model in training and held out.

    The effect's model nests the base (the effect at its neutral value is the base), so its
    training RMSE can only be above a base fit's when its own search stopped short. A base
    refit whose training RMSE is below (1 − min_improvement) times the effect model's, and
    whose held-out NRMSE is no worse, shows that the effect was named from a poor minimum:
    its gain was measured against a base far from the base's best.
    """
    fit = named.get('fit')
    if fit is None or named.get('validation_nrmse') is None:
        return False
    return (refit.train['rmse'] < (1.0 - min_improvement) * fit.train['rmse']
            and refit.validation['nrmse'] <= named['validation_nrmse'])


def _judge_on_cores(jobs: int, tasks: list) -> Iterator[dict]:
    """Yield the `judge_candidate` entries of `tasks`, on `jobs` processes (0: every core)."""
    workers = min(jobs or available_cores(), len(tasks))
    if workers <= 1:
        yield from map(judge_candidate, tasks)
    else:
        yield from (entry for _, entry in imap_on_cores(judge_candidate, tasks, workers))


def rank_candidates(base: ModelFit, entries: list, gain: str = 'improvement') -> 'Diagnosis':
    """
    Return the `Diagnosis` of judged entries: significant first, by held-out gain.

    gain: the entry key the significant ones are ranked by ('typical_gain' after
    `typical_pass`); the others by their whole-window improvement. A significant entry
    that an unresolved candidate clearly outgains held out is made not significant first
    (`_yield_to_unresolved_rivals`); the first significant entry left is the missing effect.
    """
    def key(c: dict) -> tuple:
        value = c.get(gain) if c['significant'] else c['improvement']
        return c['significant'], -np.inf if value is None else value

    for c in entries:
        if c['significant']:
            _yield_to_unresolved_rivals(c, entries)
    out = sorted(entries, key=key, reverse=True)
    _rank_retarders_by_training(out, gain)
    best = next((c for c in out if c['significant']), None)
    _flag_near_ties(out, gain)
    return Diagnosis(base, out, None if best is None else best['effect'])


def _rank_retarders_by_training(ranked: list, gain: str = 'improvement') -> None:
    """
    Put first, in their places in `ranked`, the significant retarder that fits training best.

    A dead time d and a first-order lag of about d (`Effect.retards_response`) shift the
    response to the duty alike to first order in ω d. Where the base misfits the held-out
    window, which of the two fits that window better is chance; the training window, over
    twice as long, tells them apart by likelihood: the BIC change against the same base
    (each adds one parameter), the lower one first. It decides only where it clearly does,
    its training NRMSE at least `NEAR_TIE` below the held-out leader's; where the two fit
    training about alike, the held-out order stands.
    """
    places = [i for i, c in enumerate(ranked)
              if c['significant'] and getattr(CATALOG.get(c['effect']), 'retards_response',
                                              False)]
    group = [ranked[i] for i in places]
    best = min(group, key=lambda c: c['bic_change'], default=None)
    if best is None or best is group[0]:
        return
    other = group[0]
    fits = [c['fit'].train['nrmse'] for c in (best, other)]
    if fits[0] > (1.0 - NEAR_TIE) * fits[1]:
        return
    said = f' Ranked before {other["effect"]}'
    if said not in best['explanation']:
        best['explanation'] += (
            f'{said}, which gains more held out ({100 * other[gain]:+.0f} % against '
            f'{100 * best[gain]:+.0f} %): it fits the training window clearly better '
            f'(NRMSE {100 * fits[0]:.2f} % against {100 * fits[1]:.2f} %, BIC change '
            f'{best["bic_change"]:+.1f} against {other["bic_change"]:+.1f}), and a dead time '
            'and a lag shift the response alike, so the longer window tells them apart.')
    group.remove(best)
    for i, c in zip(places, [best] + group):
        ranked[i] = c


def _yield_to_unresolved_rivals(entry: dict, entries: list) -> None:
    """
    Make the significant `entry` not significant when an unresolved rival clearly gains more.

    A candidate that passed every check but resolution (`unresolved_by`: a delay below one
    sample, a lag below half a sample, a heating law on records at one duty level) and
    gains more held out than `entry` is another explanation of the same data that these
    records cannot confirm: at 10 Hz a 50 ms delay and a 0.1 s lag shift the sampled
    response alike. When `entry` comes within `NEAR_TIE` of its gain, the data barely
    separate the two and the resolved one stays named, its explanation naming the rival;
    when the rival gains clearly more, naming `entry` would be a guess, so it is made not
    significant ('rival' holds the rival's name).
    """
    # both gains are set: entry is significant, a rival passed check 1
    rivals = [c for c in entries if c.get('unresolved') and c is not entry
              and c['improvement'] > entry['improvement']]
    if not rivals:
        return
    c = max(rivals, key=lambda r: r['improvement'])
    reason, remedy = c['unresolved']
    clearly = entry['improvement'] < (1.0 - NEAR_TIE) * c['improvement']
    said = f" {c['effect']} fits the held-out window better"
    if said in entry['explanation']:
        return   # ranked again after a later pass
    entry['explanation'] += (
        (' Not named:' if clearly else '') + said
        + f" ({100 * c['improvement']:+.0f} % against {100 * entry['improvement']:+.0f} %) "
        f'but is not resolved ({reason}): {remedy} to separate them.')
    if clearly:
        entry.update(significant=False, rival=c['effect'])


def diagnose_rounds(data: Any, base: ModelFit, rounds: int, **kw: Any) -> tuple:
    """
    Diagnose, add the missing effect, refit, diagnose again: up to `rounds` rounds.

    Stops when nothing is significant. The refit of a round is the named candidate's own
    refit (base grid, warm start, also from scratch for `own_grid` effects). Returns
    (the Diagnosis of every round, [{'added': name, 'validation_nrmse': x}, ...], the
    final ModelFit). A round whose diagnosis refitted its base (`Diagnosis.refitted`) also
    has 'refitted_base_nrmse', the held-out NRMSE of that better base fit; after a last
    round that names nothing the final fit is its base, refitted or not. With two effects
    or more added, each is judged again next to the others (`prune_effects`); one that is
    no longer significant leaves the final fit, and its round gets 'removed': True and
    'validation_nrmse_without', the held-out NRMSE once it is removed. kw:
    passed to `diagnose` (candidates, progress, jobs, ...).
    """
    diags, added = [], []
    for _ in range(max(int(rounds), 1)):
        diag = diagnose(data, base=base, **kw)
        diags.append(diag)
        base = diag.baseline
        best = next((c for c in diag.candidates if c['effect'] == diag.missing_effect), None)
        if best is None:
            break
        added.append({'added': best['effect'],
                      'validation_nrmse': best['fit'].validation['nrmse']})
        if diag.refitted:
            added[-1]['refitted_base_nrmse'] = base.validation['nrmse']
        base = best['fit']
    if len(added) >= 2:
        base, removed = prune_effects(data, base, **kw)
        for r in removed:
            entry = next(a for a in added if a['added'] == r['removed'])
            entry.update(removed=True, validation_nrmse_without=r['validation_nrmse'])
    return diags, added, base


def prune_effects(data: Any, fit: ModelFit, **kw: Any) -> tuple:
    """
    Drop the named effects the others make redundant; return (the fit, [{'removed', ...}]).

    The rounds add one effect at a time, each judged against the model before it, and a
    later effect can take over what an earlier one stood in for (a current limit for an
    unmodelled lag). So each effect is judged again as if it were the last one missing:
    the model with the others, refitted warm from `fit`, is diagnosed with that effect
    as the only candidate (all four checks of `diagnose`). One that is not named again is
    removed, and the check starts over on the smaller model. Each entry has the removed
    'removed' effect and the held-out 'validation_nrmse' of the model without it.
    kw: passed to `diagnose` (progress, jobs; the candidates are the fit's effects).
    """
    kw = {k: v for k, v in kw.items() if k != 'candidates'}
    removed = []
    while len(fit.effects) >= 2:
        for name in fit.effects:
            rest = tuple(e for e in fit.effects if e != name)
            kind = None if get_effect(name).kind else fit.kind
            diag = diagnose(data, base=fit_model(data, rest, kind=kind, base_fit=fit),
                            candidates=[name], **kw)
            if diag.missing_effect != name:
                fit = diag.baseline
                removed.append({'removed': name, 'validation_nrmse': fit.validation['nrmse']})
                break
        else:
            break
    return fit, removed


def _flag_near_ties(ranked: list, gain: str = 'improvement') -> None:
    """
    Say in each explanation which significant candidates come within NEAR_TIE of the best.

    Their order stays the held-out one: by BIC the parameter count would decide (their
    training fits are alike), against effects with more parameters whatever held-out says.
    """
    sig = [c for c in ranked if c['significant']]
    if len(sig) < 2:
        return
    top = max(c[gain] for c in sig)   # the first may be a retarder ranked by training
    group = [c for c in sig if c[gain] >= (1.0 - NEAR_TIE) * top]
    if len(group) < 2:
        return
    names = ', '.join(c['effect'] for c in group)
    for c in group:
        if ' Near tie: ' in c['explanation']:
            continue   # ranked again after a later pass
        c['explanation'] += (f' Near tie: {names} improve the held-out error within '
                             f'{100 * NEAR_TIE:.0f} % of each other; the data barely '
                             'separate them.')
