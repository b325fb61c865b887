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
(docs/workbench.md, "Recording a rig for the workbench"). `model_design` takes the design's
τ, full-stroke duty and layout from a fitted model file.
"""
from __future__ import annotations

import functools
from pathlib import Path
import time
from typing import Any, List, Mapping, Optional, Sequence, Tuple

import numpy as np
from scipy.optimize import brentq

from ..core.excitation import HOLD_TAUS, LEVEL_FRACTIONS

#: Longest excitation written [s] (a day).
MAX_DURATION_S = 86_400.0
#: Share of the model's largest contraction y_max that counts as the full stroke (y_max
#: itself is reached only at the saturation corner, beyond which any hotter wire holds it).
FULL_STROKE_SHARE = 0.98


def full_stroke_duty(params: Any, wire: int = 0) -> float:
    """
    Return the steady duty that holds a wire at `FULL_STROKE_SHARE` x y_max (0-1).

    The root in d of held(d) - FULL_STROKE_SHARE y_max (Brent's method), where held(d) is
    the wire's contraction after 30 τ at duty d from cold in the model's own forward
    simulation (`core.actuator.simulate`, every effect of the fit); held rises with d
    (the heating branch of the loop). 1 when the model needs more than full duty.
    wire: 0 for wire a, 1 for wire b (the other wire cold).
    """
    from ..core.actuator import simulate
    y_full = FULL_STROKE_SHARE * params.hysteresis.output_range()[1]
    tau_s = params.tau_s * (params.tau_ratio_b if wire else 1.0)
    steps, dt_s = 1200, tau_s / 40.0

    @functools.lru_cache(maxsize=None)   # brentq evaluates d = 1 again
    def shortfall(duty: float) -> float:
        duties = [np.zeros(steps), np.zeros(steps)]
        duties[wire] += duty
        trajectory = simulate(params, *duties, dt_s)
        return float((trajectory.y_a, trajectory.y_b)[wire][-1]) - y_full

    if shortfall(1.0) < 0.0:
        return 1.0
    return float(brentq(shortfall, 0.0, 1.0, xtol=1e-9))


def model_design(spec: Mapping[str, Any],
                 params: Any) -> Tuple[float, Tuple[float, float], str, List[str]]:
    """
    Return (tau_s, (duty_full_a, duty_full_b), layout, notes) of a fitted model file.

    spec: the file's dict; params: its `ActuatorParams`. τ = C / hA (eq. 7) of the fit;
    the layout the file records (default antagonistic). The full-stroke duty of each
    wire is the model's (`full_stroke_duty`; unequal wires differ) when the fit's records
    heat at several duty levels; when they heat at one, the heating law is not
    identified, the model's full-stroke duty is an extrapolation, and the records' own
    level is taken for both wires: the excitation then holds 0.5-1 x the level the records
    show the wire moving at.
    """
    notes = []
    levels = spec.get('duty_levels') if isinstance(spec.get('duty_levels'), dict) else {}
    profile = spec.get('tau_profile') if isinstance(spec.get('tau_profile'), dict) else {}
    if profile.get('identified') is False:
        notes.append(f"tau {params.tau_s:.3g} s is not identified by the fit's records "
                     '(tau_profile); the holds may be too short or too long')
    layout = str(spec.get('layout', 'antagonistic'))
    level = levels.get('level')
    if levels.get('one_level') and isinstance(level, (int, float)) and 0 < level <= 1:
        duty_full = (float(level), float(level))
        notes.append(f"the fit's records heat at one duty level ({level:.3g}): the "
                     'heating law is not identified, so --duty-full is that level')
    else:
        duty_a = full_stroke_duty(params)
        duty_full = (duty_a, duty_a if layout == 'single' else full_stroke_duty(params, 1))
    return float(params.tau_s), duty_full, layout, notes


def design_lines(duration_s: float, rate_hz: float, tau_s: float, duty_full: float,
                 layout: str, seed: int, duty_full_b: Optional[float] = None,
                 switch_gap_s: float = 0.0) -> Sequence[str]:
    """Return the lines that describe an excitation (the CSV's comment lines, stdout)."""
    hold_lo, hold_hi = (f * tau_s for f in HOLD_TAUS)
    duties = ', '.join(f'{duty_full * f:.3g}' for f in LEVEL_FRACTIONS)
    if layout != 'single' and duty_full_b is not None and duty_full_b != duty_full:
        duties_b = ', '.join(f'{duty_full_b * f:.3g}' for f in LEVEL_FRACTIONS)
        duties = f'{duties} (wire b: {duties_b})'
    wires = ('one wire against a bias spring (duty_b 0)' if layout == 'single'
             else 'an antagonistic pair, one wire heated at a time'
             + (f', {switch_gap_s:g} s at zero duty between them' if switch_gap_s else ''))
    return [f'identification excitation: {duration_s:g} s at {rate_hz:g} Hz for {wires}',
            f'holds of {hold_lo:.3g}-{hold_hi:.3g} s ({HOLD_TAUS[0]:g}-{HOLD_TAUS[1]:g} x tau '
            f'{tau_s:.3g} s) at duties {duties} or 0, seed {seed}',
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
