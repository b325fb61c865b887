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

"""`sma-model diagnose`: refit with each candidate effect, rank them, name the missing one."""
from __future__ import annotations

import argparse
from typing import Any, List, Mapping

from .steps import (all_data, check_effect_names, data_lines, duty_levels_doc, join_records,
                    lead_in_lines, load_checked_records, model_line, note, prepare_outputs,
                    print_json, Progress, read_model_spec, tau_profile_doc, try_lead_in)
from ..remaining import percent as _pct, PROG, remaining_lines, rounds_lines


def cmd_diagnose(args: argparse.Namespace) -> int:
    """Run `sma-model diagnose`: refit with each candidate effect, rank by held-out improvement."""
    from ..diagnosis import diagnose_rounds
    from ..engine import fit_model
    catalog = prepare_outputs(args)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    if args.candidates:
        check_effect_names(args.candidates, catalog, '--candidates')
    kind = args.kind or spec.get('kind')
    loaded = load_checked_records(args, spec)
    data = join_records(args, loaded)
    for line in data_lines(data):
        note(args, line)
    progress = Progress('base fit')
    try:
        base = fit_model(data, effects=tuple(spec['effects']), kind=kind, progress=progress)

        def refit(**lead: Any) -> tuple:
            led = join_records(args, loaded, **lead)
            return led, fit_model(led, effects=tuple(spec['effects']), kind=kind,
                                  progress=progress)
        led, lead = try_lead_in(args, loaded, base, data, refit)
        data, base = led or (data, base)
        progress.stage = 'diagnose'
        diags, rounds, base = diagnose_rounds(data, base, args.rounds, candidates=args.candidates,
                                              progress=progress, jobs=args.jobs)
        profile = tau_profile_doc(args, data, diags[0].baseline, progress)
        profile |= duty_levels_doc(data, diags[0].baseline)
    finally:
        progress.close()
    doc = _diagnosis_doc(args, diags, rounds, base, profile)
    if args.report:
        _write_diagnose_report(args, data, diags[0], doc, lead, loaded)
    if args.json:
        print_json(doc)
    else:
        _print_diagnosis(args, doc, diags[0], profile, catalog)
    return 0


def _diagnosis_doc(args: argparse.Namespace, diags: list, rounds: list, base: Any,
                   profile: dict) -> dict:
    """Return the JSON of a diagnosis: the first round's keys, then the rounds and final."""
    doc = diags[0].to_json()
    doc['baseline'].update(profile)
    if args.rounds > 1:
        doc['rounds'] = rounds
        doc['rounds_limit'] = args.rounds
        doc['final'] = {'effects': list(base.effects),
                        'validation_nrmse': base.validation['nrmse'],
                        'train_nrmse': base.train['nrmse']}
        if diags[-1].refitted and diags[-1].missing_effect is None:
            doc['final']['refitted'] = diags[-1].refitted
        if diags[-1].training_lead:
            doc['final']['training_lead'] = diags[-1].training_lead
    return doc


def _write_diagnose_report(args: argparse.Namespace, data: Any, first: Any, doc: dict,
                           lead: Any, loaded: list) -> None:
    """Write the HTML report: the base model, the named effect's fit and the rounds' plot."""
    from ..report import save_rounds_plot, write_diagnosis_report
    index = write_diagnosis_report(args.report, data, first,
                                   f'{PROG} diagnose: {" ".join(all_data(args))}',
                                   '; '.join(data_lines(data) + lead_in_lines(lead, loaded)),
                                   force=args.force, doc=doc)
    note(args, f'report: {index}')
    if args.rounds > 1 and doc.get('rounds'):
        note(args, f'rounds: {save_rounds_plot(args.report, doc)}')


def _print_diagnosis(args: argparse.Namespace, doc: dict, first: Any, profile: dict,
                     catalog: Mapping[str, Any]) -> None:
    """Print the diagnosis as text, with a note for each reason not to trust its ranking."""
    print('\n'.join(diagnosis_lines(doc, first.baseline.kind)))
    val = first.baseline.validation or {}
    if val.get('informative') is False:
        print(f'note: the held-out part covers {100 * val["coverage"]:.0f} % of the '
              'measured range, too little to rank effects reliably (hold out another '
              'record: give two or more records, or --validate-on)')
    if profile.get('tau_profile', {}).get('identified') is False:
        print(f'note: {profile["tau_profile"]["note"]}; a held-out error from a wrong τ '
              'is not a missing effect')
    if profile.get('duty_levels', {}).get('one_level'):
        laws = ', '.join(n for n, e in catalog.items() if e.heating_law)
        print(f'note: {profile["duty_levels"]["note"]}; so no effect on the heating law '
              f'({laws}) is named here')
    if args.rounds > 1:
        print('\n'.join(rounds_lines(doc, args.rounds)))


def diagnosis_lines(doc: Mapping[str, Any], kind: str) -> List[str]:
    """Return the text table of a diagnosis document, best candidate first."""
    base = doc['baseline']
    floor = base.get('noise_floor_nrmse')
    lines = [f'baseline: {model_line(base["effects"], kind)}, validation NRMSE '
             f'{_pct(base["validation_nrmse"])}'
             + (f' (the measurement noise alone: {_pct(floor)})' if floor else '')]
    if 'refitted' in base:
        lines.append(f'  {base["refitted"]}')
    lines.append(f'{"effect":<20} {"val. NRMSE":>10} {"improvement":>11}  significant')
    for c in doc['candidates']:
        imp = 'n/a' if c['improvement'] is None else f'{100 * c["improvement"]:+.0f} %'
        lines.append(f'{c["effect"]:<20} {_pct(c["validation_nrmse"]):>10} {imp:>11}  '
                     f'{"yes" if c["significant"] else "no"}')
    missing = doc['missing_effect']
    unresolved = [] if missing else [c for c in doc['candidates'] if c.get('not_resolved')]
    why = ('the candidates that cut the held-out error are not resolved by these records'
           if unresolved else 'no candidate cuts the held-out error clearly')
    lines.append(f'missing effect: {missing}' if missing else f'missing effect: none ({why})')
    lines += [f'  {c["effect"]} cuts it by {100 * c["improvement"]:.0f} %, not resolved: '
              f'{c["not_resolved"]}' for c in unresolved]
    lines += [f'  {c["effect"]} passed every check, but {c["rival"]} cuts the held-out error '
              'more: not named' for c in doc['candidates'] if c.get('rival') and not missing]
    if missing:
        c = next(c for c in doc['candidates'] if c['effect'] == missing)
        lines.append(f'  {c["explanation"]}')
    lines += ['  ' + line for line in remaining_lines(doc)]
    if missing:
        lines.append(f'  next: {PROG} fit DATA --add {missing} ... --out FITTED.yaml')
    return lines
