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

"""`sma-model compare`: score a fitted model on DATA, break the error down, test it."""
from __future__ import annotations

import argparse
from typing import Any, Dict, List, Mapping

from .steps import (all_data, COMPARED, DATA_KINDS, data_lines, fitted_model, join_records,
                    load_checked_records, mark_warm, model_line, model_signals, noise_score_line,
                    note, note_lead_in, prepare_outputs, print_json, read_fitted_spec,
                    UsageError)
from ..remaining import PROG
from ...core.datakinds import DynamicData, Split, StaticData


def cmd_compare(args: argparse.Namespace) -> int:
    """Run `sma-model compare`: score a fitted model on DATA, break the error down, test it."""
    from ..compare import compare, score_line, summary_lines
    from ..engine import model_travel, noise_floor
    from ..leadins import lead_ins
    from ...core.model_file import is_static_model
    catalog = prepare_outputs(args)
    spec = read_fitted_spec(args.model, catalog)
    loaded = load_checked_records(args, spec)
    names = ' '.join(all_data(args))
    first = loaded[0][1]
    fitted_on = StaticData if is_static_model(spec) else DynamicData
    if fitted_on.kind != first.kind:
        raise UsageError(f'{args.model} was fitted on {fitted_on.noun} but '
                         f'{names} is {first.noun}')
    check_rig(spec, first, args.model)
    lead = lead_ins(fitted_model(args, spec), loaded) if first.joinable else {}
    led_lines = note_lead_in(args, lead, loaded)
    data = join_records(args, loaded, **lead)
    fit = fitted_model(args, spec, data)
    profile = spec.get('tau_profile')
    if isinstance(profile, dict) and profile.get('identified') is False:
        note(args, f'note: {args.model}: {profile.get("note") or "τ was not identified"}')
    _note_other_levels(args, spec.get('duty_levels'), data)
    kind = DATA_KINDS[data.kind]
    records = kind.records(data, fit.prediction, role=COMPARED)
    mark_warm(records, lead)
    mark_untared(records, fit.untared)
    _note_start_offsets(args, data, records)
    result = compare(data, fit.prediction, model_signals(fit, data),
                     split=Split(0) if len(records) > 1 else None)
    travel = model_travel(fit.params, data)
    if travel:
        _note_quiet_records(args, data, travel)
    title = f'{PROG} compare: {names} with {args.model}'
    lines = data_lines(data, COMPARED)
    floor = noise_floor(data)
    noise = noise_score_line(floor, data, result.scores, result.unit)
    if args.report:
        _write_report(args, result, title,
                      '; '.join(lines + led_lines + ([noise.strip()] if noise else [])), spec)
    if args.json:
        doc = {'data': str(args.data[0]) if len(all_data(args)) == 1 else all_data(args),
               'model': {'effects': spec['effects'], 'kind': spec.get('kind')}}
        doc |= result.to_json()
        doc |= kind.json(data, records)
        if travel:
            doc['model_travel'] = travel
        doc['noise_floor_nrmse'] = floor
        print_json(doc)
    else:
        print('\n'.join(lines))
        print(f'model: {model_line(spec["effects"], spec.get("kind") or "modified")}')
        for r in records if len(records) > 1 else []:
            print(score_line(r['data'], r['scores']['all'], result.unit, 0))
        print('\n'.join(summary_lines(result, noise=noise)))
    return 0


def _note_other_levels(args: argparse.Namespace, fitted: Any, data: Any) -> None:
    """Note a compared record that heats at other duty levels than the one-level fit."""
    from ..levels import heated_duties, ONE_LEVEL_SHARE, share_at
    if not (isinstance(fitted, dict) and fitted.get('one_level')
            and data.kind == DynamicData.kind):
        return
    try:
        level, tol = float(fitted['level']), float(fitted['tolerance'])
    except (KeyError, TypeError, ValueError):
        return
    heated = heated_duties(data)
    share = share_at(heated, level, tol)
    if heated.size and share < ONE_LEVEL_SHARE:
        note(args, f'note: {args.model} was fitted at one duty level ({level:.3g} ± {tol:.2g}); '
             f'{100 * (1 - share):.0f} % of the heated time here is at other duty levels, '
             "where the model's heating law is not identified")


def _note_quiet_records(args: argparse.Namespace, data: Any, travel: float) -> None:
    """
    Note compared records that move less than `engine.MIN_COVERAGE` of the model's travel.

    Their NRMSE is over their own small range: an error that is small against the stroke
    can read as hundreds of percent there, so the RMSE is the figure to read.
    """
    from ..engine import MIN_COVERAGE
    moved = data.span()
    if moved < MIN_COVERAGE * travel:
        unit = data.output_unit
        note(args, f'note: the compared records move {moved:.4g} {unit}, '
                   f"{100 * moved / travel:.0f} % of the model's travel ({travel:.4g} {unit}): "
                   'their NRMSE, over that range, says little; read the RMSE')


def mark_untared(records: List[Dict[str, Any]], untared: Mapping[str, float]) -> None:
    """
    Mark the compared records `engine.load_fit` predicted from their own start rest.

    Their `start_offset` stays the offset from the model's rest, and `untared` is True.
    """
    for r in records:
        if r['data'] in untared:
            r['start_offset'] = float(untared[r['data']])
            r['untared'] = True


def _note_start_offsets(args: argparse.Namespace, data: Any,
                        records: List[Dict[str, Any]]) -> None:
    """
    Note each compared record predicted from its own start rest (`mark_untared`).

    Those are the records `records.untared_offsets` finds read by an untared sensor (one
    led in warm or cooling does not start at rest).
    """
    unit = data.output_unit
    for r in records:
        if r.get('untared'):
            note(args, f'note: {r["data"]} starts at rest {r["start_offset"]:+.4g} {unit} from '
                 "the model's rest (an untared sensor?): predicted from its own start rest "
                 '(fit with --add sensor_zero to refer every record to its own start rest)')


def check_rig(spec: Mapping[str, Any], data: Any, source: str) -> None:
    """Raise UsageError if the model file's position unit or layout differ from the data's."""
    for key, value in data.rig().items():
        want = spec.get(key)
        if want is not None and want != value:
            raise UsageError(f'{source}: fitted with {key} {want}, but the data has {value} '
                             f'(give --{key.replace("_", "-")} {want} if that is wrong)')


def _write_report(args: argparse.Namespace, comparison: Any, title: str, data_line: str,
                  model: Mapping[str, Any]) -> None:
    """Write the HTML report of --report and name its index on the note stream."""
    from ..report import write_report
    index = write_report(args.report, comparison, title, data_line=data_line, model=model,
                         force=args.force)
    note(args, f'report: {index}')
