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
What a diagnosis leaves to find, in words: a model's errors over the measurement noise.

`sma-model diagnose` prints these lines and its report (and each record's report of
`sma-model batch`) shows them: from the NRMSE the noise alone gives (`engine.noise_floor`),
whether the model explains the data, where the held-out part cannot judge, and which
candidates the data could not test.
"""
from __future__ import annotations

from typing import Any, List, Mapping, Optional, Sequence

#: the command the texts tell the user to run
PROG = 'sma-model'


def percent(x: Optional[float]) -> str:
    """Return the fraction x as a percentage text ('n/a' for None)."""
    return 'n/a' if x is None else f'{100 * x:.2f} %'


def noise_line(floor: float, span: float, nrmse: Mapping[str, Optional[float]],
               unit: str = '', width: int = 10) -> str:
    """
    Return the noise's score line beside `compare.score_line`'s, and each part's multiple.

    floor: the NRMSE the measurement noise alone gives (`engine.noise_floor`), over the
    measured range `span` [unit]; nrmse: {part: the model's NRMSE} ('train', 'validation'
    or 'all'; None is left out). A model within 1.5 times the noise (`NEAR_NOISE`) leaves
    nothing to find; far beyond it, `sma-model diagnose` looks for what is missing.
    """
    times = ', '.join(f'{part} {x / floor:.{1 if x < 10 * floor else 0}f} times'
                      for part, x in nrmse.items() if x is not None)
    return (f'{"noise":>{width}}: NRMSE {percent(floor)}  RMSE {floor * span:.4g}'
            f'{" " + unit if unit else ""}, the measurement noise alone'
            + (f' (the model: {times} that)' if times else ''))


def rounds_lines(doc: Mapping[str, Any], limit: int) -> List[str]:
    """
    Return the text of the add-and-refit rounds: the validation error falling.

    doc: the diagnose JSON document with 'rounds' and 'final'; limit: the rounds asked for
    (`--rounds`): rounds that reach it were stopped, not ended by a round naming nothing.
    Ends with what the final model leaves over the noise (`left_to_explain`).
    """
    lines = [f'rounds: baseline validation NRMSE {percent(doc["baseline"]["validation_nrmse"])}']
    for i, r in enumerate(doc['rounds'], 1):
        if 'refitted_base_nrmse' in r:
            lines.append(f'  round {i}: base refitted       validation NRMSE '
                         f'{percent(r["refitted_base_nrmse"])}')
        lines.append(f'  round {i}: + {r["added"]:<20} validation NRMSE '
                     f'{percent(r["validation_nrmse"])}')
    stopped = len(doc['rounds']) >= limit
    lines.append(f'  stopped after {limit} rounds (--rounds)' if stopped
                 else '  then nothing is significant')
    for r in (r for r in doc['rounds'] if r.get('removed')):
        lines.append(f'  then - {r["added"]:<20} validation NRMSE '
                     f'{percent(r["validation_nrmse_without"])} (not significant next to the '
                     'others)')
    final = doc.get('final', {})
    if 'refitted' in final and not stopped:
        lines.append(f'  final: {final["refitted"]}, validation NRMSE '
                     f'{percent(final["validation_nrmse"])}')
    floor = doc['baseline'].get('noise_floor_nrmse')
    # stopped by the limit, the last round named an effect: more may be missing
    added = ' + '.join(e for e in final.get('effects', ())
                       if e not in doc['baseline']['effects']) if stopped else ''
    if floor and final.get('validation_nrmse') is not None:
        lines.append('  ' + left_to_explain(final['validation_nrmse'] / floor,
                                            final['train_nrmse'] / floor, untried(doc), added))
    if final.get('training_lead') and not stopped:
        lines.append('  ' + lead_line(final['training_lead'], final['train_nrmse']))
    return lines


def remaining_lines(doc: Mapping[str, Any]) -> List[str]:
    """
    Return what the first round of a diagnosis document leaves to find, one text per line.

    Nothing named: the base's errors over the noise (`left_to_explain`) and the training
    lead, if any (`lead_line`); an effect named: the model with it, over the noise. Empty
    where the document has no noise floor (static curves).
    """
    base = doc['baseline']
    floor = base.get('noise_floor_nrmse')
    missing = doc.get('missing_effect')
    lines = []
    if missing:
        c = next(c for c in doc['candidates'] if c['effect'] == missing)
        if floor and c.get('train_nrmse') is not None:
            lines.append(left_to_explain(c['validation_nrmse'] / floor,
                                         c['train_nrmse'] / floor, untried(doc), missing))
        return lines
    if floor and base.get('validation_nrmse') is not None:
        lines.append(left_to_explain(base['validation_nrmse'] / floor,
                                     base['train_nrmse'] / floor, untried(doc)))
    if doc.get('training_lead'):
        lines.append(lead_line(doc['training_lead'], base['train_nrmse']))
    return lines


def untried(doc: Mapping[str, Any]) -> List[str]:
    """Return 'effect: why' of each candidate not tried for what the data lack (`data_lack`)."""
    return [f'{c["effect"]}: {c["data_lack"]}' for c in doc.get('candidates', ())
            if c.get('data_lack')]


def left_to_explain(held_out: float, train: float, not_tried: Sequence[str] = (),
                    named: str = '') -> str:
    """
    Return what is left to find, from a model's errors over the noise.

    held_out, train: the model's held-out and training NRMSE over the NRMSE the
    measurement noise alone gives (`engine.noise_floor`); not_tried: 'effect: why' of the
    catalog's effects these data could not test (`untried`), named where an effect remains.
    named: '' for the base when nothing is named; else the effects the model has beyond
    the base ('delay', or 'delay + convection' after the rounds): where its errors stay off
    the noise, the next round looks for more (or the effect's fit is short of its best).
    """
    from .engine import held_out_cannot_judge, NEAR_NOISE   # numpy and the fits: when used
    noise = 'what the measurement noise alone gives'
    lead = f'with {named} ' if named else ''
    if held_out_cannot_judge(held_out, train):
        return (f'{lead}the held-out error is {held_out:.1f} times {noise}, but the training '
                f'error {train:.0f} times: the held-out part does not show what the training '
                'part lacks (hold out a record that moves as the training does: --validate-on)')
    if held_out <= NEAR_NOISE:
        return (f'{lead}the held-out error is {held_out:.1f} times {noise}: the model '
                'explains the data')
    if train <= NEAR_NOISE:
        return (f'{lead}the held-out error is {held_out:.0f} times {noise}, the training error '
                f'{train:.1f} times: the held-out part goes where training did not (give '
                'longer or more varied records)')
    remains = (f'{lead}the held-out error is {held_out:.0f} times {noise}, the training error '
               f'too {train:.0f} times: '
               + (f'the model with {named} does not explain all of the data yet (diagnose '
                  'again with it in the model: --rounds)' if named else
                  'an effect the catalog does not hold, or one too weak to separate, remains'))
    if not_tried:
        remains += '; not tried, for what the data lack: ' + '; '.join(not_tried)
    return remains


def lead_line(lead: Mapping[str, Any], train: float) -> str:
    """Return the text of a diagnosis' training lead (`diagnosis.training_lead`), a hint."""
    return (f'the training window is fitted best with {lead["effect"]} (training NRMSE '
            f'{percent(train)} -> {percent(lead["train_nrmse"])}, BIC change '
            f'{lead["bic_change"]:+.0f}; held out {percent(lead["validation_nrmse"])}), '
            'which the held-out part cannot confirm: a lead to test on a record that shows '
            f'it ({PROG} fit DATA --add {lead["effect"]}, then compare other records), not '
            'a name')
