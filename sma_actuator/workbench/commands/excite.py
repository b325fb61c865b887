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

"""`sma-model excite`: write an identification excitation in the rig's own time scale."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Tuple

from .steps import fitted_model, read_fitted_spec, UsageError


def cmd_excite(args: argparse.Namespace) -> int:
    """Run `sma-model excite`: write an identification excitation in the rig's time scale."""
    from ...core.excitation import rig_excitation
    from ...core.model_file import check_writable
    from ..excite import design_lines, write_bag, write_csv
    tau_s, (full_a, full_b), layout = _excite_design(args)
    out = Path(args.out)
    csv_out = out.suffix.lower() == '.csv'
    check_writable(out, args.force, directory=not csv_out)
    dt_s = 1.0 / args.rate
    duty_a, duty_b = rig_excitation(args.duration, dt_s, tau_s, full_a, layout, args.seed,
                                    duty_full_b=full_b, switch_gap_s=args.switch_gap_s)
    lines = design_lines(args.duration, args.rate, tau_s, full_a, layout, args.seed,
                         duty_full_b=full_b, switch_gap_s=args.switch_gap_s)
    if csv_out:
        write_csv(out, duty_a, duty_b, dt_s, lines)
    else:
        write_bag(out, duty_a, duty_b, dt_s, overwrite=args.force)
    for line in lines[:2]:
        print(line)
    print(f'wrote {out}')
    return 0


def _excite_design(args: argparse.Namespace) -> Tuple[float, Tuple[float, float], str]:
    """Return excite's (tau_s, (duty_full_a, duty_full_b), layout): the flags, else --model's."""
    from ...core.identification import MAX_TAU_S
    from ...core.model_file import is_static_model
    from ..excite import MAX_DURATION_S, model_design
    tau_s, layout = args.tau_s, args.layout
    duty_full = None if args.duty_full is None else (args.duty_full, args.duty_full)
    if args.model:
        spec = read_fitted_spec(args.model, None)   # effect names do not matter here
        if is_static_model(spec):
            raise UsageError(f'{args.model}: a static (curve) fit has no thermal time '
                             'constant; give --tau-s and --duty-full')
        design = model_design(spec, fitted_model(args, spec).params)
        for note in design[3]:
            print(f'note: {note}')
        tau_s = design[0] if tau_s is None else tau_s
        duty_full = design[1] if duty_full is None else duty_full
        layout = design[2] if layout is None else layout
    elif tau_s is None or duty_full is None:
        raise UsageError('give --tau-s and --duty-full, or --model FITTED.yaml')
    if not tau_s <= MAX_TAU_S:
        raise UsageError(f'tau {tau_s:g} s is over {MAX_TAU_S:g} s, the largest '
                         'time constant the fit takes')
    if not max(duty_full) <= 1:
        raise UsageError(f'--duty-full {max(duty_full):g} is over 1 (the duty is 0-1)')
    if not 10 * tau_s <= args.duration <= MAX_DURATION_S:
        raise UsageError(f'--duration {args.duration:g} s is outside 10 x tau '
                         f'({10 * tau_s:g} s) to {MAX_DURATION_S:g} s')
    return tau_s, duty_full, layout or 'antagonistic'
