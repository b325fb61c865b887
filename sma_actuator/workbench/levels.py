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
Whether the training records identify the heating law: the duty levels they heat at.

The steady temperature rise is P(u) / (h A) (eq. 7 at rest), with the Joule power
P = u R min(V/R, I_max)² linear in the duty u and the heat loss h A (θ − θa) linear in the
temperature (eq. 7). Records that heat at one duty level show that rise at one heating
power only, so a heat loss that is not linear in the temperature (`convection`), a power
that is not linear in the duty (`current_limit`) or depends on the phase
(`phase_resistance`), or a second thermal node (`fast_dynamics`) fits them about as well
as the linear law does, the free hysteresis weights re-placed, and predicts other duty
levels far off. `duty_levels` finds the level most of the heated time is spent at.
"""
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..core.datakinds import DynamicData, Split

#: a sample is heated when a duty exceeds this share of the largest duty
HEATED_SHARE = 0.05
#: duties within this share of the largest duty of a level are at that level
LEVEL_TOLERANCE = 0.10
#: the records heat at one level when it holds at least this share of the heated samples
#: (a step or a square wave at one duty, with the ramp or the edges that lead to it)
ONE_LEVEL_SHARE = 0.75


@dataclass
class DutyLevels:
    """The duty level most heated samples share, and how many do."""

    level: float        # the duty [0..1]
    tolerance: float    # ± this duty counts as the level
    share: float        # share of the heated samples (both wires) at the level

    @property
    def one_level(self) -> bool:
        """Return True when ONE_LEVEL_SHARE of the heated samples are at the level."""
        return self.share >= ONE_LEVEL_SHARE

    def to_json(self) -> dict:
        """Return the JSON / model-file form (duties 0..1, share as a fraction, the note)."""
        return {'one_level': self.one_level, 'level': self.level, 'tolerance': self.tolerance,
                'share': self.share, 'min_share': ONE_LEVEL_SHARE, 'note': self.note()}

    def note(self) -> str:
        """Return one line for the user when the records heat at one level ('' otherwise)."""
        if not self.one_level:
            return ''
        return (f'the training records heat at one duty level ({100 * self.share:.0f} % of '
                f'the heated time at duty {self.level:.3g} ± {self.tolerance:.2g}): a heat '
                'loss or heating power that is not linear (convection, current_limit) is not '
                'identified, and other duty levels are extrapolated; fit with a record that '
                'holds two or three other duty levels (a staircase; `sma-model excite '
                '--model FITTED.yaml` writes its duty sequence)')


def heated_duties(data: DynamicData, split: Optional[Split] = None) -> np.ndarray:
    """
    Return the duties of both wires on the training samples where they heat.

    Training: the training samples of `split` (`split_masks`; None: every measured sample);
    heated: a duty above HEATED_SHARE of the largest duty on those samples.
    """
    train, _ = data.split_masks(split or Split(len(data)))
    duties = np.concatenate([data.duty_a[train], data.duty_b[train]])
    top = duties.max(initial=0.0)
    return duties[duties > HEATED_SHARE * top] if top > 0 else duties[:0]


def duty_levels(data: DynamicData, split: Optional[Split] = None) -> Optional[DutyLevels]:
    """
    Return the duty level the most heated training samples share (None: nothing heated).

    The level is the median of the largest set of heated duties within 2 LEVEL_TOLERANCE ×
    the largest duty of each other (a sliding window over the sorted duties); its share
    counts the heated duties within ± LEVEL_TOLERANCE × the largest duty of it.
    """
    duties = np.sort(heated_duties(data, split))
    if duties.size == 0:
        return None
    tol = LEVEL_TOLERANCE * duties[-1]
    ends = np.searchsorted(duties, duties + 2.0 * tol, side='right')
    first = int(np.argmax(ends - np.arange(duties.size)))
    level = float(np.median(duties[first:ends[first]]))
    return DutyLevels(level, float(tol), share_at(duties, level, tol))


def share_at(duties: np.ndarray, level: float, tolerance: float) -> float:
    """Return the share of `duties` within ± `tolerance` of `level` (0 for none)."""
    if duties.size == 0:
        return 0.0
    return float(np.count_nonzero(np.abs(duties - level) <= tolerance) / duties.size)
