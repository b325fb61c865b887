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
Whether a record's held-out window lies on the loop where its training window has been.

A wire's position depends on the branch of its loop it moves on: rising (heating) from the
last turn at the bottom, falling (cooling) from the last turn at the top (eq. 6, the
modified PI operator). A model fitted on a training window knows each branch over the
positions the window moved through on it; beyond them the branch is extrapolated, as in
the cooling tail of a record whose training part ends while the wire cools. A held-out
gain won there says which extrapolation happens to fit, not which effect is missing.
`extrapolated_share` measures how much of a time split's held-out window lies there, and
`extrapolated_error_share` how much of a model's held-out error.
"""
from typing import Any, Optional, Tuple

from numba import njit
import numpy as np

from ..core.datakinds import DynamicData

#: a branch turns where the position comes back by this share of the measured range
TURN_SHARE = 0.02
#: a held-out sample beyond the positions its branch trained on by this share of the range
#: lies where training never was
OUTSIDE_SHARE = 0.05
#: the held-out window does not judge effects when more than this share of it lies there
MOSTLY_EXTRAPOLATED = 0.5


@njit(cache=True)
def branch_of(position: np.ndarray, turn: float) -> np.ndarray:
    """
    Return the branch of each sample: +1 rising, −1 falling, 0 before the first move.

    A zigzag filter: the branch changes where the position comes back from its last
    extreme by more than `turn` [position unit], so noise smaller than that is no turn.
    """
    branch = np.zeros(position.size, np.int8)
    low = high = position[0]
    state = 0
    for k in range(position.size):
        y = position[k]
        if state >= 0 and y > high:
            high = y
        if state <= 0 and y < low:
            low = y
        if state >= 0 and y < high - turn:
            state, low = -1, y
        elif state <= 0 and y > low + turn:
            state, high = 1, y
        branch[k] = state
    return branch


def held_out_beyond(data: Any) -> Optional[Tuple[int, np.ndarray]]:
    """
    Return (split start, which held-out samples lie beyond their trained branches), or None.

    For one dynamic record split in time (None otherwise: a held-out record of a rig's
    set may rest or reach elsewhere on other days, `sensor_zero`, `record_stroke`): a
    held-out sample lies beyond when its position is more than `OUTSIDE_SHARE` of the
    measured range beyond the positions the training window took on the same branch
    (`branch_of`, turns at `TURN_SHARE` of the range).
    """
    if not isinstance(data, DynamicData) or data.split or len(data.segments) > 1:
        return None
    y = np.asarray(data.position, float)
    span = float(np.ptp(y))
    start = data.default_split().start
    if span <= 0 or not 0 < start < y.size:
        return None
    branch = branch_of(y, TURN_SHARE * span)
    tol = OUTSIDE_SHARE * span
    held = y[start:]
    beyond = np.zeros(held.size, bool)
    for side in (1, -1):
        trained = y[:start][branch[:start] == side]
        on_side = branch[start:] == side
        if trained.size == 0:
            beyond |= on_side
        else:
            beyond |= on_side & ((held < trained.min() - tol) | (held > trained.max() + tol))
    return start, beyond


def extrapolated_share(data: Any) -> Optional[float]:
    """Return the share of the held-out window beyond its trained branches (`held_out_beyond`)."""
    found = held_out_beyond(data)
    return None if found is None else float(np.mean(found[1]))


def extrapolated_error_share(data: Any, prediction: np.ndarray) -> Optional[float]:
    """
    Return the share of a prediction's held-out squared error beyond the trained branches.

    Σ_beyond e_k² / Σ_held-out e_k², e = y − ŷ over the held-out window's finite samples
    (`held_out_beyond`); None where that does not apply or the prediction is exact.
    """
    found = held_out_beyond(data)
    if found is None:
        return None
    start, beyond = found
    error = np.asarray(data.position, float)[start:] - np.asarray(prediction, float)[start:]
    finite = np.isfinite(error)
    squared = np.where(finite, error, 0.0) ** 2
    total = float(squared.sum())
    return float(squared[beyond].sum() / total) if total > 0 else None
