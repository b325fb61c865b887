#!/usr/bin/env python3
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

r"""
Write one hidden-effect recording (CSV) from the rich SMA simulator.

    python test/support/make_hidden_dataset.py --effect delay --magnitude 1 \\
        --excitation closed --noise-rad 0.002 --rate-hz 40 --duration-s 600 --seed 3 \\
        --out /tmp/hidden/delay_closed.csv

Columns: time,duty_a,duty_b,position,ambient_temperature[,setpoint] (s, 0..1, rad, degC, rad).
"""
import argparse
from pathlib import Path
import sys

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))   # make `support` importable

from support.richsim import EFFECTS, EXCITATIONS, simulate, write_csv  # noqa: E402


def parse_args(argv=None):
    """Command-line options (see module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--effect', required=True, choices=sorted(EFFECTS))
    ap.add_argument('--magnitude', type=float, default=1.0)
    ap.add_argument('--excitation', choices=EXCITATIONS, default='open')
    ap.add_argument('--noise-rad', type=float, default=0.002)
    ap.add_argument('--rate-hz', type=float, default=40.0)
    ap.add_argument('--duration-s', type=float, default=600.0)
    ap.add_argument('--seed', type=int, default=0)
    ap.add_argument('--out', required=True, type=Path)
    return ap.parse_args(argv)


def main(argv=None):
    """Simulate, write the CSV, print a one-line summary; return the exit code."""
    args = parse_args(argv)
    try:
        data = simulate(args.effect, args.magnitude, args.excitation, args.duration_s,
                        args.rate_hz, args.noise_rad, args.seed)
    except ValueError as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(data, args.out)
    pos = data['position']
    print(f'{args.out}: {pos.size} samples, position [{pos.min():.3f}, {pos.max():.3f}] rad')
    return 0


if __name__ == '__main__':
    sys.exit(main())
