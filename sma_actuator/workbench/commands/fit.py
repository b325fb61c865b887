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

"""`sma-model fit`: fit the base model plus effects, score each record, write FITTED.yaml."""
from __future__ import annotations

import argparse
from typing import Any, Dict, List, Optional, Sequence, Tuple

from .steps import (check_effect_names, DATA_KINDS, data_lines, duty_levels_doc, join_records,
                    load_checked_records, mark_warm, model_line, noise_score_line, note,
                    prepare_outputs, print_json, Progress, read_model_spec, record_lines,
                    tau_profile_doc, try_lead_in)
from ...core.datakinds import DynamicData


def cmd_fit(args: argparse.Namespace) -> int:
    """Run `sma-model fit`: fit the base model plus effects; print scores; write FITTED.yaml."""
    from ..compare import score_line
    from ..engine import noise_floor
    from ...core.model_file import write_model
    catalog = prepare_outputs(args)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    add = args.add or []
    check_effect_names(add, catalog)
    effects = list(dict.fromkeys(spec['effects'] + add))
    kind = args.kind or spec.get('kind')
    loaded = load_checked_records(args, spec)
    progress = Progress('fit')
    try:
        data, fit, records = _fit_records(args, loaded, tuple(effects), kind, progress)
        led, lead = try_lead_in(args, loaded, fit, data, lambda **lead: _fit_records(
            args, loaded, tuple(effects), kind, progress, **lead))
        if led:
            data, fit, records = led
        mark_warm(records, lead)
        profile = tau_profile_doc(args, data, fit, progress) | duty_levels_doc(data, fit)
    finally:
        progress.close()
    if profile.get('tau_profile', {}).get('identified') is False:
        note(args, f'note: {profile["tau_profile"]["note"]}')
    if profile.get('duty_levels', {}).get('one_level'):
        note(args, f'note: {profile["duty_levels"]["note"]}')
    if 'sensor_zero' not in fit.effects and data.kind == DynamicData.kind:
        _note_apart_rests(args, loaded, data)
    if args.out:
        write_model(args.out, dict(fit.to_dict(), **profile), force=args.force)
    floor = noise_floor(data)
    if args.json:
        print_json(dict(fit_json(fit, args.out, records), **profile, noise_floor_nrmse=floor))
    else:
        print(f'model: {model_line(fit.effects, fit.kind)} ({fit.n_parameters} parameters)')
        if fit.values:
            print('fitted: ' + ', '.join(f'{k} = {v:.4g}' for k, v in fit.shown_values().items()))
        unit = data.output_unit
        for r in records if len(records) > 1 else []:
            print(score_line(f'{r["data"]} ({r["role"]})', r['scores']['all'], unit, 0,
                             r['role'] != 'train'))
        print(score_line('train', fit.train, unit))
        print(score_line('validation', fit.validation, unit))
        parts = {'train': fit.train, 'validation': fit.validation}
        noise = noise_score_line(floor, data, parts, unit)
        if noise:
            print(noise)
    if args.out:
        note(args, f'wrote {args.out}')
    return 0


def _fit_records(args: argparse.Namespace, loaded: List[Tuple[str, Any]], effects: tuple,
                 kind: Optional[str], progress: Progress, **lead: Any) -> tuple:
    """
    Fit the records; return (data, fit, per-record rows).

    Several records without --validate-on: each left out in turn (`crossval`); else one
    split. lead: `records.join`'s lead_in and tau_s (`leadins.lead_ins`); the records
    are described (notes) only on the first fit, the one without.
    """
    from ..crossval import all_records, cross_validate, LEFT_OUT
    from ..engine import fit_model
    if len(loaded) > 1 and not args.validate_on:
        if not lead:
            notes = []
            lines = record_lines(all_records(loaded, notes), LEFT_OUT)
            for line in notes + lines:
                note(args, line)
            note(args, 'validation: each record predicted by the model fitted on the others; '
                 f'the model written is fitted on all {len(loaded)} (--validate-on to hold '
                 'records out)')
        return cross_validate(loaded, effects, kind, jobs=args.jobs, progress=progress,
                              **lead)
    data = join_records(args, loaded, **lead)
    for line in [] if lead else data_lines(data):
        note(args, line)
    fit = fit_model(data, effects=effects, kind=kind, progress=progress)
    return data, fit, per_record(fit, data)


def per_record(fit: Any, data: Any) -> List[Dict[str, Any]]:
    """Return the per-record scores of a dynamic fit ([] for static curves)."""
    return DATA_KINDS[data.kind].records(data, fit.prediction, fit.split)


def fit_json(fit: Any, out: Optional[str],
             records: Sequence[Dict[str, Any]] = ()) -> Dict[str, Any]:
    """Return the `fit --json` document."""
    val = fit.validation or {}
    doc = {'effects': list(fit.effects), 'kind': fit.kind,
           'train_nrmse': fit.train['nrmse'], 'validation_nrmse': val.get('nrmse'),
           'parameters': fit.shown_values(), 'n_parameters': fit.n_parameters,
           'train': fit.train, 'validation': fit.validation,
           'out': str(out) if out else None}
    if records:
        doc['records'] = list(records)
    doc.update(fit.rig)
    return doc


def _note_apart_rests(args: argparse.Namespace, loaded: List[Tuple[str, Any]],
                      data: DynamicData) -> None:
    """
    Note records of a fit whose start rests lie further apart than a rest scatters.

    Apart by more than `records.UNTARED_SHARE` of the measured range of the joined `data`,
    the sensor was most likely not tared between them, which `sensor_zero` takes up.
    """
    from ..records import start_rests, UNTARED_SHARE
    rests = start_rests(loaded)
    if len(rests) < 2:
        return
    span, unit = data.span(), data.output_unit
    low, high = min(rests, key=rests.get), max(rests, key=rests.get)
    if rests[high] - rests[low] > UNTARED_SHARE * span:
        note(args, f'note: the records start at rests {rests[high] - rests[low]:.4g} {unit} '
             f'apart ({high} at {rests[high]:.4g} {unit}, {low} at {rests[low]:.4g} {unit}; '
             f'{100 * UNTARED_SHARE:.0f} % of the range is {UNTARED_SHARE * span:.3g} {unit}): '
             'an untared sensor? fit with --add sensor_zero to refer each record to its own '
             'start rest, or see what diagnose names')
