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

"""Argument checks shared by the core: clear errors that name the parameter, never a silent NaN."""
from __future__ import annotations

from typing import Any

import numpy as np


def finite_array(name: str, value: Any, ndim: int = 1, min_len: int = 1) -> np.ndarray:
    """Return `value` as a float64 array of `ndim` dimensions with only finite entries."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim != ndim:
        raise ValueError(f'{name} must be a {ndim}-D array, got shape {arr.shape}')
    if arr.shape[0] < min_len:
        raise ValueError(f'{name} must have at least {min_len} entries, got {arr.shape[0]}')
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = int(np.flatnonzero(bad.ravel())[0])
        raise ValueError(f'{name} contains a non-finite value (first at flat index {idx})')
    return arr


def finite_scalar(name: str, value: Any) -> float:
    """Return `value` as a finite float."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be a number, got {value!r}') from None
    if not np.isfinite(x):
        raise ValueError(f'{name} must be finite, got {x}')
    return x


def positive(name: str, value: Any, allow_zero: bool = False) -> float:
    """Return `value` as a finite float > 0 (>= 0 with allow_zero)."""
    x = finite_scalar(name, value)
    if x < 0 or (x == 0 and not allow_zero):
        raise ValueError(f'{name} must be {"non-negative" if allow_zero else "positive"}, got {x}')
    return x


def non_negative_array(name: str, value: Any) -> np.ndarray:
    """Return `value` as a finite 1-D array with no negative entry."""
    arr = finite_array(name, value, min_len=0)
    if (arr < 0).any():
        raise ValueError(f'{name} must be non-negative, got min {arr.min():g}')
    return arr


def same_length(**arrays: Any) -> None:
    """Raise if the named 1-D arrays differ in length."""
    lengths = {k: len(v) for k, v in arrays.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f'arrays must have equal length, got {lengths}')
