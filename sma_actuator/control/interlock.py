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
Dead-time interlock on the duty a wire actually gets (docs/safety.md).

Rule: a wire may heat (duty > 0) only when the other wire has had zero applied duty
for at least the dead time (to within `TIE_SHARE` of it: float rounding). A request to
heat both at once applies zero to both (there is no way to know which one was meant).
Turning a wire off is always allowed at once.

This is the one Python implementation, used by plant_sim, the hardware bridge and the
MCU emulator's `McuCore`; `firmware/sma_mcu/sma_mcu_core.cpp` (`DeadTimeInterlock`) is
its C++ twin, checked through the "mcu" scenarios of firmware/test_vectors.json.

Times are in whatever unit the caller uses (s on the host, µs ticks on the MCU); pass
`elapsed(now, then)` for a wrapping tick counter.
"""
from __future__ import annotations

import operator
from typing import Callable, Optional, Tuple

BOTH_REQUESTED = 'both wires requested at once'
DEAD_TIME = 'other wire still inside the dead time'
# a dead time missed by this share counts as elapsed: a clock that sums its periods in
# floating point puts n periods a rounding error short of n dt (0.025 s + 0.025 s from
# 1.05 s is 0.04999999999999999 s), and every clock must release a wire on the same sample
# (the controller's estimate assumes the duty it sent was applied); integer ticks are exact
TIE_SHARE = 1e-6
# the dead time [s] plant_sim and the hardware bridge apply and the controller keeps by
# default: two 25 ms control periods, twice the firmware's own 25 ms
DEFAULT_DEAD_TIME_S = 0.05


class DeadTimeInterlock:
    """Gate a requested duty pair so that the applied pair obeys the dead-time rule."""

    def __init__(self, dead_time: float,
                 elapsed: Callable[[float, float], float] = operator.sub):
        if not dead_time >= 0:
            raise ValueError(f'interlock dead time must be >= 0, got {dead_time}')
        self.dead_time = dead_time
        self.elapsed = elapsed
        self.applied = (0, 0)
        # time each wire last went from heated to zero; None: longer ago than the dead time
        self.off_since = [None, None]
        self.held = 0       # requests in which a wire was held off

    def apply(self, duty_a: float, duty_b: float,
              now: float) -> Tuple[Tuple[float, float], Optional[str]]:
        """
        Return (applied pair, reason or None) for the requested pair at time `now`.

        The reason says why a requested wire was held at zero (BOTH_REQUESTED, DEAD_TIME).
        """
        requested = (duty_a, duty_b)
        both = duty_a > 0 and duty_b > 0
        for wire in (0, 1):   # a heated wire that is not to heat any more goes off now
            if self.applied[wire] > 0 and (both or not requested[wire] > 0):
                self.off_since[wire] = now
        self.expire(now)
        out = [0 * duty_a, 0 * duty_b]   # zero of the caller's type (int counts or float)
        reason = BOTH_REQUESTED if both else None
        if not both:
            for wire in (0, 1):
                if requested[wire] > 0:
                    if self.off_since[1 - wire] is None:
                        out[wire] = requested[wire]
                    else:
                        reason = DEAD_TIME
        self.applied = tuple(out)
        if reason:
            self.held += 1
        return self.applied, reason

    def expire(self, now: float) -> None:
        """Forget turn-off times older than the dead time (call often on a wrapping clock)."""
        for wire in (0, 1):
            then = self.off_since[wire]
            if (then is not None
                    and self.elapsed(now, then) >= (1.0 - TIE_SHARE) * self.dead_time):
                self.off_since[wire] = None

    def reset(self, now: float) -> Tuple[float, float]:
        """Apply zero to both wires now (watchdog, link loss, shutdown)."""
        return self.apply(0 * self.applied[0], 0 * self.applied[1], now)[0]
