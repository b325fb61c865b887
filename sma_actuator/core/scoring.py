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
Scores of a prediction and the measurement noise they are judged against.

* `scores`: free-run simulation error, RMSE, NRMSE = RMSE / range(y),
  fit % = 100 (1 − ‖e‖ / ‖y − ȳ‖), max |e|.
* `noise_rms`, `record_noise_rms`: the white-noise σ of a measured signal from its third
  differences; `NEAR_NOISE` the factor of it within which a fit leaves nothing to find.
"""
from typing import Optional

import numpy as np

from .datakinds import DynamicData


def scores(y: np.ndarray, y_hat: np.ndarray, span: Optional[float] = None) -> dict:
    """
    Return the error figures of a prediction y_hat of measured y.

    rmse, nrmse = rmse / span, fit_percent, max_error; span defaults to the range of y
    (pass the range of the whole record set so a quiet window is not scored as a huge
    relative error).
    """
    y = np.asarray(y, float)
    e = y - np.asarray(y_hat, float)
    rmse = float(np.sqrt(np.mean(e ** 2)))
    span = float(np.ptp(y)) if span is None else float(span)
    dev = float(np.linalg.norm(y - y.mean()))
    return {'rmse': rmse,
            'nrmse': rmse / span if span > 0 else float('inf'),
            'fit_percent': 100.0 * (1.0 - np.linalg.norm(e) / dev) if dev > 0 else float('-inf'),
            'max_error': float(np.max(np.abs(e)))}


# share of the third differences kept by the fallback noise estimate, and the share of a
# normal's variance its central part of that probability mass holds
NOISE_KEPT = 0.9
NOISE_KEPT_VARIANCE = 0.623


def noise_rms(*signals: np.ndarray) -> float:
    """
    Return the RMS σ of white measurement noise on smooth signals, estimated from them.

    Third differences d_k = y_{k+2} − 3 y_{k+1} + 3 y_k − y_{k−1} cancel a signal that is
    smooth at the sampling rate (to its third derivative times dt³) and leave white noise
    of variance 20 σ², so σ = 1.4826 MAD(d) / √20, MAD the median absolute deviation,
    which ignores the few samples where the signal itself bends (steps). Each signal (one
    record) is differenced on its own. A quantised signal resting on one level has MAD 0;
    then σ² = mean of the `NOISE_KEPT` smallest d² / (20 `NOISE_KEPT_VARIANCE`), the
    rescaling a normal's trimmed variance needs.
    """
    d = np.concatenate([np.diff(np.asarray(y, float), 3) for y in signals if len(y) > 3])
    if d.size == 0:
        return 0.0
    mad = float(np.median(np.abs(d - np.median(d))))
    if mad > 0:
        return 1.4826 * mad / np.sqrt(20.0)
    kept = np.sort(d ** 2)[:max(1, int(NOISE_KEPT * d.size))]
    return float(np.sqrt(np.mean(kept) / (20.0 * NOISE_KEPT_VARIANCE)))


def record_noise_rms(data: DynamicData) -> float:
    """Return σ of `noise_rms` over each record's measured positions (the whole run if one)."""
    records = data.segments or (('', 0, len(data)),)
    return noise_rms(*(data.position[a:b] for _, a, b in records))


# a fit within this factor of the measurement noise leaves nothing to find
NEAR_NOISE = 1.5
