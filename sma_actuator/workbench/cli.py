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
`sma-model`: fit, compare and diagnose actuator models on recorded data.

    sma-model fit DATA [DATA ...] [--model MODEL.yaml] [--add EFFECT ...] [--out FITTED.yaml]
    sma-model compare DATA [DATA ...] --model FITTED.yaml [--report DIR] [--json]
    sma-model diagnose DATA [DATA ...] [--model MODEL.yaml] [--rounds N] [--report DIR]
    sma-model batch DATA... --out DIR [--model MODEL.yaml] [--rounds N] [--scheduler ADDRESS]
    sma-model effects [--json]        (the catalog, with plug-ins)
    sma-model excite (--tau-s S --duty-full D | --model FITTED.yaml) --out OUT.csv|BAG

Every command also takes --plugin FILE.py|MODULE (repeatable) to add user effects, and
--force to overwrite existing output files; DATA commands take --validate-on DATA ...,
--layout single|antagonistic and --position-unit UNIT. Bad input ends with exit code 2 and one line
``sma-model: error: ...`` on stderr, before any output file is written. Progress goes to
stderr: a bar on a terminal, otherwise plain lines for long stages and large files. See
docs/workbench.md. This module parses the command line; each command runs in its module of
`workbench.commands`.
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Any, Optional, Sequence

from .parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads: a fit must not depend on --jobs
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)

import numpy as np  # noqa: E402, I100

from .commands.batch import cmd_batch  # noqa: E402, I100
from .commands.compare import cmd_compare  # noqa: E402
from .commands.diagnose import cmd_diagnose  # noqa: E402
from .commands.effects import cmd_effects  # noqa: E402
from .commands.excite import cmd_excite  # noqa: E402
from .commands.fit import cmd_fit  # noqa: E402
from .commands.steps import EXIT_BAD_INPUT, EXIT_INTERRUPTED  # noqa: E402
from .limits import MAX_FIT_RATE_HZ  # noqa: E402
from .remaining import PROG  # noqa: E402

MAX_RATE_HELP = ('records sampled faster are decimated to this rate or below for fitting '
                 '(duty: block means; position: means centred on each kept sample) [Hz] '
                 '(default: %(default)g)')


class OneLineParser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line `sma-model: error: ...` and exit code 2."""

    def error(self, message: str) -> None:
        """Print the one-line error and exit 2 (argparse's default prints the usage too)."""
        self.exit(EXIT_BAD_INPUT, f'{PROG}: error: {message} (see {self.prog} --help)\n')


def build_parser() -> argparse.ArgumentParser:
    """Return the argparse parser of `sma-model` (one-line errors, exit code 2)."""
    common = _common_options()
    parser = OneLineParser(prog=PROG, description='Compare the SMA actuator model with '
                           'measurements, find the missing physical effect, add it.')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND',
                                parser_class=OneLineParser)
    for add_command in (_add_fit, _add_compare, _add_diagnose, _add_batch, _add_effects,
                        _add_excite):
        add_command(sub, common)
    return parser


def _common_options() -> argparse.ArgumentParser:
    """Return the parent parser of the options that fit, compare and diagnose share."""
    common = argparse.ArgumentParser(add_help=False, parents=[_reading_options()])
    common.add_argument('data', metavar='DATA', nargs='+',
                        help='CSVs (dynamic or static curves) or MCAP bags (file or '
                        'directory); several dynamic records of one rig are fitted together')
    common.add_argument('--validate-on', nargs='+', action='extend', metavar='DATA',
                        help='hold these records out for validation (default: fit: each of '
                        'several records left out in turn, the model written fitted on all; '
                        'diagnose: the last record; one record: the last 30 %% of time)')
    common.add_argument('--plugin', action='append', metavar='FILE.py|MODULE',
                        help='load user effects from a Python file or module (repeatable)')
    common.add_argument('--json', action='store_true', help='print the result as JSON')
    common.add_argument('--force', action='store_true', help='overwrite existing output files')
    return common


def _reading_options() -> argparse.ArgumentParser:
    """Return the parent parser of how records are read (fit, compare, diagnose, batch)."""
    reading = argparse.ArgumentParser(add_help=False)
    reading.add_argument('--layout', choices=('single', 'antagonistic'),
                         help='rig layout (default: from the data; single = one wire against '
                         'a bias spring, duty_b absent or always 0)')
    reading.add_argument('--position-unit', type=_position_unit, metavar='UNIT',
                         help='unit of position and setpoint (default: from the header, e.g. '
                         'position[mm], or a "# ... position in mm" comment; else rad)')
    reading.add_argument('--column', action='append', type=_column_pair, default=[],
                         metavar='NAME=HEADER',
                         help="read a CSV's column HEADER as NAME, e.g. position[mm]=pot_mm, "
                         'time[ns]=__time (repeatable; NAME: time, duty_a, duty_b, duty, '
                         'position, ambient_temperature, setpoint)')
    reading.add_argument('--rate', type=_positive_float, metavar='HZ',
                         help='resampling rate for MCAP bags [Hz] (default: joint-state rate)')
    reading.add_argument('--max-rate', type=_positive_float, metavar='HZ',
                         default=MAX_FIT_RATE_HZ, help=MAX_RATE_HELP)
    reading.add_argument('--keep-glitches', action='store_true',
                         help='read positions that jump away and back within 3 samples '
                         '(30 ms above 100 Hz) as measured (default: bridged as sensor '
                         'glitches, not scored)')
    return reading


def _add_fit(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `fit`: fit a model to DATA, print scores, write it with --out."""
    fit = sub.add_parser('fit', parents=[common], help='fit a model, print scores',
                         description='Fit the base model plus effects to DATA.')
    fit.add_argument('--model', metavar='MODEL.yaml', help='effects (and kind) to start from')
    fit.add_argument('--add', nargs='+', action='extend', metavar='EFFECT',
                     help='effects to add to the model')
    fit.add_argument('--kind', choices=('classical', 'modified'),
                     help='hysteresis base (default: from MODEL.yaml, else modified)')
    fit.add_argument('--out', metavar='FITTED.yaml', help='write the fitted model')
    fit.add_argument('--jobs', type=_non_negative_int, default=0, metavar='N',
                     help='processes for the fits of several records, each left out in turn '
                     '(default 0: every core)')
    fit.set_defaults(func=cmd_fit)


def _add_compare(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `compare`: score a fitted model on DATA and say where it fails."""
    cmp_ = sub.add_parser('compare', parents=[common], help='where a fitted model fails',
                          description='Score a fitted model on DATA, break the error down '
                          'by regime and test the residual.')
    cmp_.add_argument('--model', required=True, metavar='FITTED.yaml',
                      help='fitted model (from fit --out)')
    cmp_.add_argument('--report', metavar='DIR', help='write an HTML report with figures')
    cmp_.set_defaults(func=cmd_compare)


def _add_diagnose(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `diagnose`: rank the catalog effects by held-out error reduction."""
    dia = sub.add_parser('diagnose', parents=[common], help='find the missing effect',
                         description='Refit with each candidate effect and rank them by '
                         'held-out error reduction.')
    dia.add_argument('--model', metavar='MODEL.yaml', help='base model (default: paper model)')
    dia.add_argument('--kind', choices=('classical', 'modified'),
                     help='hysteresis base (default: from MODEL.yaml, else modified)')
    dia.add_argument('--candidates', nargs='+', action='extend', metavar='EFFECT',
                     help='only try these effects (default: every catalog effect)')
    dia.add_argument('--report', metavar='DIR', help='write an HTML report with figures')
    dia.add_argument('--jobs', type=_non_negative_int, default=0, metavar='N',
                     help='processes for the candidate refits (default 0: every core)')
    dia.add_argument('--rounds', type=_positive_int, default=1, metavar='N',
                     help='add the missing effect, refit and diagnose again, up to N rounds, '
                     'stopping when nothing is significant (default 1)')
    dia.set_defaults(func=cmd_diagnose)


def _add_batch(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `batch`: fit, compare and diagnose many records on Dask."""
    bat = sub.add_parser('batch', parents=[_reading_options()],
                         help='fit, compare and diagnose many records (Dask)',
                         description='Run fit, compare and diagnose on every record, on a '
                         'Dask cluster; write a table (Parquet, CSV) and an HTML index.')
    bat.add_argument('data', nargs='+', metavar='DATA',
                     help='CSV files, MCAP bags, directories or globs')
    bat.add_argument('--out', required=True, metavar='DIR',
                     help='output directory (results are resumed from it)')
    bat.add_argument('--model', metavar='MODEL.yaml',
                     help='effects (and kind) to start from; a fitted model (fit --out) is '
                     'also compared with every record (column reference_nrmse)')
    bat.add_argument('--kind', choices=('classical', 'modified'),
                     help='hysteresis base (default: from MODEL.yaml, else modified)')
    bat.add_argument('--candidates', nargs='+', action='extend', metavar='EFFECT',
                     help='only try these effects (default: every catalog effect)')
    bat.add_argument('--rounds', type=_positive_int, default=1, metavar='N',
                     help='diagnose rounds: add the named effect and diagnose again (default 1)')
    bat.add_argument('--scheduler', metavar='ADDRESS',
                     help='a running Dask scheduler, e.g. tcp://10.0.0.5:8786 '
                     '(default: a local cluster on every core)')
    bat.add_argument('--workers', type=_positive_int, metavar='N',
                     help='local cluster size in processes (default: every core)')
    bat.add_argument('--no-reports', action='store_true', help='skip the per-record reports')
    bat.add_argument('--force', action='store_true', help='recompute finished records')
    bat.add_argument('--json', action='store_true', help='print a JSON summary')
    bat.add_argument('--plugin', action='append', metavar='FILE.py|MODULE',
                     help='load user effects from a Python file or module (repeatable); '
                     'every worker loads them, so a file must be at that path on each')
    bat.set_defaults(func=cmd_batch)


def _add_effects(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `effects`: list the effect catalog."""
    eff = sub.add_parser('effects', help='list the effect catalog (with plug-ins)',
                         description='List every effect: parameters, physics, signature.')
    eff.add_argument('--plugin', action='append', metavar='FILE.py|MODULE',
                     help='load user effects from a Python file or module (repeatable)')
    eff.add_argument('--json', action='store_true', help='print the catalog as JSON')
    eff.set_defaults(func=cmd_effects)


def _add_excite(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add `excite`: write an identification excitation for a rig."""
    from ..core.excitation import SWITCH_GAP_S
    exc = sub.add_parser('excite', help='write an identification excitation for a rig',
                         description='Write the duty sequence of an identification record '
                         "in the rig's own time: holds of 0.75-2.5 tau at six duties from "
                         '0.5 to 1 x --duty-full. OUT.csv: time,duty_a,duty_b for your own '
                         'logger; any other OUT: a bag of /sma/duty commands for `replay`.')
    exc.add_argument('--model', metavar='FITTED.yaml',
                     help="take tau, the full-stroke duty and the layout from a fit's model "
                     'file (the flags below override each)')
    exc.add_argument('--tau-s', type=_positive_number, metavar='S',
                     help='thermal time constant of the wire [s] (the fitted tau_s)')
    exc.add_argument('--duty-full', type=_positive_number, metavar='D',
                     help='the duty that holds a wire at its full stroke (0-1)')
    exc.add_argument('--layout', choices=('single', 'antagonistic'),
                     help='single: one wire against a bias spring, duty_b 0 (default: '
                     "--model's, else antagonistic: one wire of the pair heated at a time)")
    exc.add_argument('--duration', type=_positive_number, default=480.0, metavar='S',
                     help='length of the record [s] (default 480: 8 minutes)')
    exc.add_argument('--rate', type=_positive_float, default=40.0, metavar='HZ',
                     help="duty command rate [Hz] (default 40, the controller's)")
    exc.add_argument('--seed', type=_non_negative_int, default=0, metavar='N',
                     help='random seed of the sequence (default 0)')
    exc.add_argument('--switch-gap-s', type=_non_negative_number, default=SWITCH_GAP_S,
                     metavar='S',
                     help='zero duty where heating passes from one wire to the other [s] '
                     f"(default {SWITCH_GAP_S:g}: longer than hardware_bridge's 0.05 s "
                     'interlock dead time, so the bridge applies every command and the '
                     'recorded duty is the applied one)')
    exc.add_argument('--out', required=True, metavar='OUT.csv|BAG',
                     help='CSV file, or bag directory for `replay`')
    exc.add_argument('--force', action='store_true', help='overwrite OUT')
    exc.set_defaults(func=cmd_excite)


def _column_pair(text: str) -> str:
    """Check one ``NAME=HEADER`` of --column (argparse type)."""
    from .data import parse_column_map
    try:
        parse_column_map([text])
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return text


def _position_unit(text: str) -> str:
    """Return the canonical spelling of a position unit (argparse type)."""
    from .data import parse_unit
    try:
        return parse_unit(text, '--position-unit')
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err).partition(': ')[2]) from None


def _positive_float(text: str) -> float:
    """Parse a positive rate [Hz] within the accepted range (argparse type)."""
    from .limits import MAX_RATE_HZ, MIN_RATE_HZ
    value = _positive_number(text)
    if not MIN_RATE_HZ <= value <= MAX_RATE_HZ:
        raise argparse.ArgumentTypeError(f'{text} Hz is outside {MIN_RATE_HZ:g} to '
                                         f'{MAX_RATE_HZ:g} Hz')
    return value


def _number(text: str) -> float:
    """Parse a decimal number (argparse type; NaN and infinity parse)."""
    from .limits import parse_number
    try:
        return parse_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text[:40]!r} is not a number') from None


def _positive_number(text: str) -> float:
    """Parse a positive finite number (a time [s], a duty; argparse type)."""
    value = _number(text)
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f'{text!r} is not a positive number')
    return value


def _non_negative_number(text: str) -> float:
    """Parse a finite number >= 0 (a time [s]; argparse type)."""
    value = _number(text)
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f'{text!r} is not a number >= 0')
    return value


def _positive_int(text: str) -> int:
    """Parse an integer >= 1 (argparse type)."""
    value = _non_negative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f'{text!r} is not a positive integer')
    return value


def _non_negative_int(text: str) -> int:
    """Parse an integer >= 0 (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not an integer') from None
    if value < 0:
        raise argparse.ArgumentTypeError(f'{text!r} is negative')
    return value


def error_text(err: BaseException) -> str:
    """Return one line for an input error (OSError: file and reason)."""
    if isinstance(err, OSError) and err.strerror:
        text = f'{err.filename}: {err.strerror}' if err.filename else err.strerror
    else:
        text = str(err) or type(err).__name__
    return ' '.join(text.split())


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of `sma-model`; returns the exit code (0 ok, 2 bad input, 130 interrupt)."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except BrokenPipeError:   # stdout closed early (e.g. piped into head): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (ValueError, OSError) as err:
        print(f'{PROG}: error: {error_text(err)}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f'{PROG}: interrupted', file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == '__main__':
    sys.exit(main())
