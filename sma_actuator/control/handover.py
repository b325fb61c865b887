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
Handover at a zero crossing of the signed contraction target (mode pi_inverse).

At a zero crossing of Δy* the incoming wire is near ambient and must heat to the start of
its transformation θs (As, `tuning.transformation_start_c`) before the shaft moves: at
full duty T ln(G / (G − (θs − θa))), 0.8 s for Flexinol, a lag the PI cannot remove. The
outgoing wire meanwhile holds its cooling branch with a small duty, and the two wires are
never heated at once nor within the dead time of each other (`control.interlock`; the
controller gates its own output with it).

With t_c = (φ0 − p⁻¹(r)) / ṙ the predicted time to the crossing (`ControllerCore`):

* free preheat (t_c within `free_lead_s`: 3 s, or 3.75 times a slower incoming wire's
  heating time to θs; while the loop gives the outgoing wire zero duty, as after a
  reversal, when it cools through its loop): the incoming wire gets the duty that takes
  its estimate θ̂ towards θpre = θa + f (θs − θa), f = `PREHEAT_FRACTION`, in one sample.
  Below θs it does not move. If the loop already heats it more (it pulls the shaft), the
  loop's command stands;
* early handover, once t_c <= LEAD t_need (`LEAD`), t_need = T ln((G − (θ̂ − θa)) / (G −
  (θs − θa))) + the dead time, the time at full duty to θs:
  1. the outgoing wire is heated to θburst = θa + (θ* − θa) e^{HOLD t_c / T} (`HOLD`, at
     most `MAX_BURST_K` above the inverse's target θ*): heated inside its loop it keeps its
     contraction while it then cools, for about HOLD t_c;
  2. the incoming wire gets the exact thermal inverse to θs over the horizon t_c, so that
     it starts to move when the reference crosses (the outgoing one is let go).
  The handover lasts until the reference has crossed.
* both only while the model's open-loop reading follows the measurement (`observe`,
  `TRUST_RAD`): they act on the model's word for up to a second.

A step (ṙ = 0) or a reference that does not head for a crossing gets neither.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple, TYPE_CHECKING

if TYPE_CHECKING:
    from .feedforward import InverseFeedforward


# early handover: at most this far ahead [s]; start at LEAD t_need; hold burst HOLD t_c,
# at most MAX_BURST_K [K] above the target (0.05 Hz sine, docs/controller.md)
MAX_LEAD_S = 2.0
LEAD = 0.9
HOLD = 0.3
MAX_BURST_K = 8.0
# free preheat (`Preheat._free_preheat`): fraction of the way from ambient to θs, and its
# window before the crossing [s]: FREE_LEAD_S, or FREE_LEAD_HEATS times the incoming wire's
# heating time from ambient to θs at full duty when that is longer (3 s is 3.75 times
# Flexinol's 0.8 s; a slower wire gets the same window in its own time)
PREHEAT_FRACTION = 0.85
FREE_LEAD_S = 3.0
FREE_LEAD_HEATS = 3.75
# model trust: RMS of measurement − model reading over `TRUST_TIME_S` below `TRUST_RAD`
# (a gross misfit: the base model on the asymmetric plant misses by 0.49 rad, a 20 % stroke
# error by 0.1 rad, plant_sim's fitted plain model by 0.025 rad)
TRUST_RAD = 0.2
TRUST_TIME_S = 5.0
# slowest reference rate [rad/s] that counts as moving towards a crossing
MIN_RATE_RAD_S = 0.01


class Preheat:
    """Early handover planner (module docstring), one call per sample."""

    def __init__(self, feedforward: InverseFeedforward, theta_start_c: float,
                 dead_time_s: float = 0.05, ambient_c: Optional[float] = None):
        self.feedforward = feedforward
        self.theta_start_c = float(theta_start_c)
        self.dead_time_s = float(dead_time_s)
        self.lead, self.hold = LEAD, HOLD
        self.free_lead_s = tuple(self._free_window_s(j, ambient_c) for j in (0, 1))
        self.mismatch_ms = 0.0
        self.reset()

    def reset(self) -> None:
        """Forget a running handover."""
        self.incoming = None
        self.burst_c = None     # θ the outgoing wire is heated to before it is let go

    def observe(self, mismatch_rad: float, dt: float) -> None:
        """
        Track how well the model's open-loop reading follows the measurement.

        m² ← m² + (e² − m²) dt / `TRUST_TIME_S`, e = y − ŷ(t − D); the handover runs only
        while m < `TRUST_RAD`: it heats on the model's word for up to a second, and a model
        that misses the plant by more than that would overheat the incoming wire.
        """
        self.mismatch_ms += (mismatch_rad ** 2 - self.mismatch_ms) * min(dt / TRUST_TIME_S, 1.0)

    @property
    def trusted(self) -> bool:
        """Whether the model's reading has followed the measurement (m < `TRUST_RAD`)."""
        return self.mismatch_ms < TRUST_RAD ** 2

    def gap(self, dt: float) -> int:
        """Return n_g = ceil(dead_time / dt), the interlock's dead time in samples."""
        return max(1, int(math.ceil(self.dead_time_s / dt - 1e-6))) if self.dead_time_s > 0 else 0

    def _free_window_s(self, j: int, ambient: Optional[float]) -> float:
        """
        Return wire j's free preheat window [s]: max(FREE_LEAD_S, FREE_LEAD_HEATS t_cold).

        t_cold: `time_needed_s` from ambient (the model's, `ambient`) to θs; a wire that
        cannot reach θs, or no ambient given, keeps FREE_LEAD_S.
        """
        cold = math.inf if ambient is None else self.time_needed_s(j, ambient, ambient)
        return max(FREE_LEAD_S, FREE_LEAD_HEATS * cold) if math.isfinite(cold) else FREE_LEAD_S

    def _free_preheat(self, incoming: int, t_cross_s: float, theta_est: Sequence[float],
                      ambient: float, dt: float, u: float) -> Optional[Tuple[float, float]]:
        """
        Heat the incoming wire towards θpre while the loop lets the outgoing one coast.

        After a reversal the outgoing wire cools through its loop at zero duty; that time
        costs it nothing, so the incoming wire takes it, up to θpre = θa + f (θs − θa)
        (f = `PREHEAT_FRACTION`), within the incoming wire's window (`free_lead_s`) of the
        crossing.
        """
        outgoing_duty = u if incoming == 1 else -u
        if outgoing_duty > 0.0 or not t_cross_s <= self.free_lead_s[incoming]:
            return None
        out = [0.0, 0.0]
        out[incoming] = self.feedforward.thermal_duty(
            incoming, ambient + PREHEAT_FRACTION * (self.theta_start_c - ambient),
            float(theta_est[incoming]), ambient, horizon_s=dt)
        if out[incoming] <= -outgoing_duty:
            return None     # the loop already heats it more (it pulls the shaft)
        return tuple(out)

    def time_needed_s(self, j: int, theta_est: float, ambient: float) -> float:
        """
        Return t_heat = T ln((G − (θ̂ − θa)) / (G − (θs − θa))) [s] of wire j.

        The time wire j needs at full duty to reach θs from θ̂ (inf when it cannot).
        """
        ff = self.feedforward
        gain, tau = ff.wire_gain(j), ff.wire_tau(j)
        x0, x1 = theta_est - ambient, self.theta_start_c - ambient
        if x0 >= x1:
            return 0.0
        if gain <= x1:
            return math.inf
        return tau * math.log((gain - x0) / (gain - x1))

    def duties(self, incoming: Optional[int], t_cross_s: float, theta_est: Sequence[float],
               ambient: float, dt: float, theta_target: Optional[Sequence[float]] = None,
               u: float = 0.0) -> Optional[Tuple[float, float]]:
        """
        Return (d_a, d_b) of this sample, or None when the loop drives the wires.

        incoming: wire (0 a, 1 b) the reference is heading for, None if it is not heading
        for a crossing; t_cross_s: predicted time to the crossing [s]; theta_est: θ̂ [°C];
        theta_target: the inverse's target temperatures θ* [°C]; u: the loop's signed
        command (+ heats a).
        """
        if (incoming is None or not self.trusted
                or (self.incoming is not None and incoming != self.incoming)):
            self.reset()
            return None
        if self.incoming is None:
            need = self.time_needed_s(incoming, float(theta_est[incoming]), ambient)
            need += self.gap(dt) * dt
            if not t_cross_s <= min(self.lead * need, MAX_LEAD_S):
                return self._free_preheat(incoming, t_cross_s, theta_est, ambient, dt, u)
            self.incoming = incoming
            out_est = float(theta_est[1 - incoming])
            branch = out_est if theta_target is None else float(theta_target[1 - incoming])
            burst = min(ambient + (branch - ambient) * math.exp(
                self.hold * t_cross_s / self.feedforward.wire_tau(1 - incoming)),
                branch + MAX_BURST_K)
            self.burst_c = burst if burst > out_est + 0.5 else None
        out = [0.0, 0.0]
        if self.burst_c is not None:
            j = 1 - incoming
            if float(theta_est[j]) < self.burst_c - 0.25:
                out[j] = self.feedforward.thermal_duty(j, self.burst_c, float(theta_est[j]),
                                                       ambient, horizon_s=dt)
                return tuple(out)
            self.burst_c = None
        out[incoming] = self.feedforward.thermal_duty(
            incoming, self.theta_start_c, float(theta_est[incoming]), ambient,
            horizon_s=max(t_cross_s, dt))
        return tuple(out)
