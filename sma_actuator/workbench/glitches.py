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
Sensor glitches in a measured position: a few samples that jump far away and straight back.

A potentiometer's wiper that lifts off its track for a moment, or a sample garbled on a
logger's line, reads far from the position before and after it. A wire cannot move so:
it contracts through its thermal lag and relaxes slower still, so a real move to a new
position does not return within a few samples, and a reversal at the top of a move exceeds
its neighbours by about one sample's motion. Left in, a few such samples widen the range
that normalises every score and pull the least-squares fit (docs/workbench.md, "Sensor
glitches").
"""
from __future__ import annotations

from typing import Tuple

import numpy as np
from scipy.ndimage import maximum_filter1d, median_filter, minimum_filter1d

#: Longest excursion read as a glitch [samples] at 100 Hz and below ...
MAX_GLITCH_SAMPLES = 3
#: ... and [s] at faster rates: a wire goes away and back only through a cooling, which takes
#: even the thinnest Flexinol wire (25 µm) about 0.1 s
MAX_GLITCH_S = 0.03
#: An excursion clears both samples around it by more than this many times the 99th
#: percentile of the record's motion per sample, |Δm| (m its running median) ...
GLITCH_STEP_FACTOR = 4.0
#: ... than this fraction of the 0.5-99.5 percentile range of m ...
GLITCH_RANGE_FRACTION = 0.1
#: ... and than this many times the 90th percentile of its noise, |y − m|.
GLITCH_NOISE_FACTOR = 5.0


def max_glitch_samples(dt_s: float) -> int:
    """
    Return the longest glitch [samples] of a record sampled every `dt_s` [s].

    max(MAX_GLITCH_SAMPLES, round(MAX_GLITCH_S / dt_s)): 3 samples up to 100 Hz, 30 ms
    above (30 samples at 1 kHz), where a wiper's lift-off of a few milliseconds spans
    more than 3 samples.
    """
    return max(MAX_GLITCH_SAMPLES, int(round(MAX_GLITCH_S / dt_s)))


def glitch_threshold(position: np.ndarray, max_samples: int = MAX_GLITCH_SAMPLES) -> float:
    """
    Return the least clearance of a glitch [unit of `position`].

    D = max(GLITCH_STEP_FACTOR · P99(|m[k+1] − m[k]|), GLITCH_RANGE_FRACTION · (P99.5(m) −
    P0.5(m)), GLITCH_NOISE_FACTOR · P90(|y − m|)), m the running median of y over
    2 `max_samples` + 1 samples: the motion, range and noise of the record without its
    glitches, which the median removes however many there are. Gaussian noise of σ gives
    P90(|y − m|) ≈ 1.6 σ, so on a record that barely moves D is still about 8 σ, and a whole
    quantum of a coarse sensor is no glitch.
    """
    y = np.asarray(position, float)
    m = median_filter(y, size=2 * max_samples + 1, mode='nearest')
    spread = np.percentile(m, 99.5) - np.percentile(m, 0.5)
    return float(max(GLITCH_STEP_FACTOR * np.percentile(np.abs(np.diff(m)), 99),
                     GLITCH_RANGE_FRACTION * spread,
                     GLITCH_NOISE_FACTOR * np.percentile(np.abs(y - m), 90)))


def excursions(position: np.ndarray, run: int, clearance: float) -> np.ndarray:
    """
    Return how far each run of `run` samples clears the samples around it [unit of y].

    Element i is for the run y[i+1..i+run] between y[i] and y[i+run+1]: min(run) −
    max(y[i], y[i+run+1]) above them, or min(y[i], y[i+run+1]) − max(run) below them,
    whichever is larger; −inf where the reading does not come back to within
    `clearance`/2 of where it left (a move, not an excursion).
    """
    y = np.asarray(position, float)
    if y.size < run + 2:
        return np.empty(0)
    count = y.size - run - 1
    # the least and greatest of y[i+1..i+run], each in one pass whatever the run's length
    lowest = minimum_filter1d(y[1:-1], run, origin=-(run // 2))[:count]
    highest = maximum_filter1d(y[1:-1], run, origin=-(run // 2))[:count]
    before, after = y[:count], y[run + 1:]
    above = lowest - np.maximum(before, after)
    below = np.minimum(before, after) - highest
    back = np.abs(after - before) <= clearance / 2
    return np.where(back, np.maximum(above, below), -np.inf)


def glitch_mask(position: np.ndarray,
                max_samples: int = MAX_GLITCH_SAMPLES) -> Tuple[np.ndarray, float]:
    """
    Return (the samples that are glitches, the clearance D of `glitch_threshold`).

    A run y[i..j] of at most `max_samples` samples is a glitch when it clears both y[i−1]
    and y[j+1] by more than D, all above them or all below (`excursions`), and y[j+1] is
    within D/2 of y[i−1]: the reading jumps away and comes back to where it was.
    """
    y = np.asarray(position, float)
    clearance = glitch_threshold(y, max_samples)
    mask = np.zeros(y.size, bool)
    if clearance <= 0:
        return mask, clearance
    for run in range(1, max_samples + 1):
        for start in np.flatnonzero(excursions(y, run, clearance) > clearance) + 1:
            mask[start:start + run] = True
    return mask, clearance
