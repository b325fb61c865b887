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
Whether the training records identify the thermal time constant τ = C / (h A) (eq. 7).

Under one heating history the temperature θ(t) rises monotonically, and the position is
the loop's ascending branch x(θ(t)). Another τ' gives another monotonic θ'(t) = g(θ(t)),
and free hysteresis weights re-place the branch, x'(θ') = x(g⁻¹(θ')), so that x(t) is
unchanged: one step, or one ramp, is fitted equally well at any τ, and the fitted τ is
where the search happened to stop. Records at two duty levels, or one that cools, tie the
branch to temperature and so τ to time. `tau_profile` refits with τ held at a factor below
and above the fitted one: where the training error does not rise, τ is not identified.
Whether they identify the heating law: `levels`.
"""
from dataclasses import dataclass
from typing import Any, Callable, Optional, Tuple

from .crossval import fit_all
from .engine import ModelFit

#: τ is held at these multiples of the fitted value
PROFILE_FACTORS = (0.5, 2.0)
#: τ counts as identified when the training RMSE at every profile point exceeds the fit's
#: by at least this fraction (a wrong τ at half or twice the value misfits a step response
#: by far more; an unidentified one fits within the search tolerance)
MIN_PROFILE_RISE = 0.10


@dataclass
class TauProfile:
    """Training error of a fit with τ held at other values."""

    fitted_tau_s: float
    fitted_nrmse: float                 # training NRMSE of the fit itself
    tau_s: Tuple[float, ...]            # the held values [s]
    train_nrmse: Tuple[float, ...]      # training NRMSE at each held value

    @property
    def identified(self) -> bool:
        """Return True when every held τ fits the training records worse by MIN_PROFILE_RISE."""
        return all(e >= (1.0 + MIN_PROFILE_RISE) * self.fitted_nrmse for e in self.train_nrmse)

    def to_json(self) -> dict:
        """Return the JSON / model-file form (NRMSE as fractions, τ in seconds, the note)."""
        return {'identified': self.identified, 'fitted_tau_s': self.fitted_tau_s,
                'fitted_train_nrmse': self.fitted_nrmse, 'tau_s': list(self.tau_s),
                'train_nrmse': list(self.train_nrmse), 'min_rise': MIN_PROFILE_RISE,
                'note': self.note()}

    def note(self) -> str:
        """Return one line for the user when τ is not identified ('' when it is)."""
        if self.identified:
            return ''
        points = [(t, e, '') for t, e in zip(self.tau_s, self.train_nrmse)]
        points.append((self.fitted_tau_s, self.fitted_nrmse, ' (fitted)'))
        profile = ', '.join(f'{100 * e:.2f} % at {t:.3g} s{tag}' for t, e, tag in sorted(points))
        return ('the training records do not identify the thermal time constant τ (training '
                f'NRMSE {profile}): other duty histories can be predicted far off; fit with '
                'a record at another duty level, or one that cools')


def tau_profile(data: Any, fit: ModelFit, factors: Tuple[float, ...] = PROFILE_FACTORS,
                jobs: int = 0, progress: Optional[Callable] = None) -> TauProfile:
    """
    Refit `fit`'s model on `data` with τ held at each factor × the fitted τ.

    Each refit starts from scratch (its own hysteresis grid), with the fit's effects and
    their other parameters free, and is scored on the same training window. The refits run
    on `jobs` processes (0: every core); progress(done, total, label) after each.
    """
    tau = float(fit.values['tau_s'])
    held = tuple(f * tau for f in factors)
    tasks = [(data, tuple(fit.effects), fit.kind, {'tau_s': t}) for t in held]
    fits = fit_all(tasks, jobs, progress, 'time-constant profile fits')
    return TauProfile(tau, float(fit.train['nrmse']), held,
                      tuple(float(f.train['nrmse']) for f in fits))
