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
`sma-model excite`: the duty sequence of an identification record for a rig (no ROS).

`core.excitation.rig_excitation` in the rig's own time constant, written as a CSV
(``time,duty_a,duty_b``, for a rig's own logger) or as a bag of ``/sma/duty`` commands that
the `replay` node plays to `hardware_bridge` while `recorder` records the run
(docs/workbench.md, "Recording a rig for the workbench").
"""
from __future__ import annotations

from pathlib import Path
import time
from typing import Sequence

import numpy as np

from ..core.excitation import HOLD_TAUS, LEVEL_FRACTIONS

#: Longest excitation written [s] (a day).
MAX_DURATION_S = 86_400.0


def design_lines(duration_s: float, rate_hz: float, tau_s: float, duty_full: float,
                 layout: str, seed: int) -> Sequence[str]:
    """Return the lines that describe an excitation (the CSV's comment lines, stdout)."""
    hold_lo, hold_hi = (f * tau_s for f in HOLD_TAUS)
    duties = ', '.join(f'{duty_full * f:.3g}' for f in LEVEL_FRACTIONS)
    wires = ('one wire against a bias spring (duty_b 0)' if layout == 'single'
             else 'an antagonistic pair, one wire heated at a time')
    return [f'identification excitation: {duration_s:g} s at {rate_hz:g} Hz for {wires}',
            f'holds of {hold_lo:.3g}-{hold_hi:.3g} s ({HOLD_TAUS[0]:g}-{HOLD_TAUS[1]:g} x tau '
            f'{tau_s:g} s) at duties {duties} or 0, seed {seed}',
            'time in s; duty_a, duty_b PWM duty 0-1, held until the next row']


def write_csv(path: Path, duty_a: np.ndarray, duty_b: np.ndarray, dt_s: float,
              lines: Sequence[str]) -> None:
    """Write ``time,duty_a,duty_b`` rows with ``lines`` as ``#`` comments above the header."""
    table = np.column_stack([np.arange(duty_a.size) * dt_s, duty_a, duty_b])
    header = '\n'.join(f'# {line}' for line in lines) + '\ntime,duty_a,duty_b'
    np.savetxt(path, table, delimiter=',', header=header, comments='',
               fmt=['%.4f', '%.4f', '%.4f'])


def write_bag(path: Path, duty_a: np.ndarray, duty_b: np.ndarray, dt_s: float,
              overwrite: bool = False) -> None:
    """
    Write a bag of /sma/duty commands [duty_a, duty_b] every dt_s, ending with [0, 0].

    overwrite: replace the bag files already in `path` (nothing else there is touched).
    """
    from ..bag.synthetic import offered_profile, SMA_TOPICS, to_cdr
    from ..bag.writer import BagWriter
    topic = '/sma/duty'
    type_name, reliability = SMA_TOPICS[topic]
    duty = np.vstack([np.column_stack([duty_a, duty_b]), [0.0, 0.0]])
    payloads = to_cdr([(type_name, {'data': [float(a), float(b)]}) for a, b in duty])
    start_ns, step_ns = time.time_ns(), int(round(dt_s * 1e9))
    with BagWriter(path, overwrite=overwrite) as bag:
        bag.add_topic(topic, type_name, [offered_profile(reliability)])
        for k, data in enumerate(payloads):
            bag.write(topic, data, start_ns + k * step_ns)
