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
How each record of a set starts: at rest, warm, or still cooling.

A log is not always begun with the wires at rest. One begun mid-run starts with a duty on
and the wires warm (`warm_starts`); one begun right after an earlier run starts at zero
duty with a wire still cooling (`cooling_starts`). `lead_ins` gives `records.join` the
lead-in each record asks of a model, so the model starts where the wire was.
"""
from typing import Any, Optional

import numpy as np

from .records import join, REST_GAP_S, rest_gap_s, segment_of, ZERO_WINDOW_S
from ..core.datakinds import DynamicData

# a record that starts with a duty on starts warm when the steady state of its first duties
# predicts its first ZERO_WINDOW_S this much closer than a start at rest (mean |error|) ...
WARM_ADVANTAGE = 0.5
# ... and the start at rest misses by more than this share of the record's range
WARM_MIN_MISS = 0.02
# a record that starts at zero duty is looked at for a cooling wire over its first
# COOL_WINDOW_S [s], or until a duty first rises ...
COOL_WINDOW_S = 5.0
# ... where it moves by more than WARM_MIN_MISS of its range (means over the first and the
# last MOTION_MEAN_S [s] of that window: sensor noise)
MOTION_MEAN_S = 0.2
# duties tried for a cooling record when no record of the set heats: geometric, up to full
UNKNOWN_HEATS = np.geomspace(0.02, 1.0, 16)
# of the heats whose lead-in matches within this factor of the best, the lowest is taken
HEAT_TIE = 1.1


def warm_starts(model: Any, records: list, tau_s: Optional[float] = None,
                confirm: bool = True) -> tuple:
    """
    Return the names of the (name, DynamicData) records that `model` sees start warm.

    A record whose first sample has a duty on was begun at rest as that duty came on, or
    logged mid-run with the wires warm. It may start warm when the model started at rest
    misses its first ZERO_WINDOW_S by more than WARM_MIN_MISS of the record's range (mean
    |measured − predicted|); with `confirm` it starts warm only if the model started in the
    steady state of its first duties (`join(..., warm=...)`) misses by less than
    WARM_ADVANTAGE times that. tau_s: the model's time constant [s] (sets the lead-in).
    """
    def start_miss(name: str, d: DynamicData, warm: tuple) -> float:
        n = min(len(d), max(1, int(round(ZERO_WINDOW_S / d.dt))))
        joined = join([(name, d)], warm=warm, tau_s=tau_s)
        a = segment_of(joined, name)[0]
        return float(np.mean(np.abs(d.position[:n] - model.simulate(joined)[a:a + n])))

    out = []
    for name, d in records:
        if d.duty_a[0] <= 0 and d.duty_b[0] <= 0:
            continue
        at_rest = start_miss(name, d, ())
        if at_rest > WARM_MIN_MISS * d.span() and (
                not confirm or start_miss(name, d, (name,)) < WARM_ADVANTAGE * at_rest):
            out.append(name)
    return tuple(out)


def cooling_window(d: DynamicData) -> int:
    """Return the samples of a record's start before any duty, at most COOL_WINDOW_S."""
    n = min(len(d), int(round(COOL_WINDOW_S / d.dt)))
    heated = np.flatnonzero((d.duty_a > 0) | (d.duty_b > 0))
    return min(n, int(heated[0])) if heated.size else n


def moves_unheated(d: DynamicData) -> bool:
    """
    Return whether a record starts at zero duty and moves before any duty comes on.

    A wire at rest holds still at zero duty; one still cooling from an earlier run does
    not. The move is |mean of the window's last MOTION_MEAN_S − mean of its first| over
    `cooling_window`, against WARM_MIN_MISS of the record's range.
    """
    if d.duty_a[0] > 0 or d.duty_b[0] > 0:
        return False
    w, k = cooling_window(d), max(1, int(round(MOTION_MEAN_S / d.dt)))
    if w < 2 * k:
        return False
    y = d.position[:w]
    return abs(float(np.mean(y[-k:]) - np.mean(y[:k]))) > WARM_MIN_MISS * d.span()


def heat_options(d: DynamicData, records: list) -> list:
    """
    Return the (duty_a, duty_b) a cooling record's wire may have been heated by.

    Each wire alone at the highest duty the record gives it, or, for a record that never
    heats, the highest the record set gives it (what the rig's runs use), or else at each
    of UNKNOWN_HEATS (`cooled_start` takes the lowest that matches). Lowest duty first.
    """
    def peak(column: str, source: list) -> float:
        return max(float(np.max(getattr(r, column))) for r in source)
    wires = ('duty_a',) if d.layout == 'single' else ('duty_a', 'duty_b')
    others = [r for _, r in records]
    peaks = [peak(w, [d]) or peak(w, others) for w in wires]
    duties = [(w, p) for w, p in zip(wires, peaks) if p > 0] or [
        (w, float(p)) for p in UNKNOWN_HEATS for w in wires]
    return sorted([(p, 0.0) if w == 'duty_a' else (0.0, p) for w, p in duties], key=sum)


def cooled_start(model: Any, name: str, d: DynamicData, heats: list,
                 tau_s: Optional[float] = None) -> tuple:
    """
    Return (miss at rest, lead-in, its miss) for a record that starts still cooling.

    The model is heated at each of `heats` for the rest gap and then cooled at zero duty
    for as long again; the lead-in (duty_a, duty_b, cool_s [s]) is the heat and the time
    into that cooling whose prediction matches the record's `cooling_window` best (least
    squares over every shift: the duty is zero there, so the cooling just goes on), the
    lowest heat within HEAT_TIE of the best (a window that shows no fall yet cannot tell
    how hot the wire was: the lowest heat that explains it falls soonest). Misses are mean
    |measured − predicted| over that window [position unit].
    """
    w = cooling_window(d)
    y = d.position[:w]
    at_rest = float(np.mean(np.abs(y - model.simulate(join([(name, d)]))[:w])))
    cool_s = rest_gap_s(tau_s)
    leads = []
    for a, b in heats:
        joined = join([(name, d)], cooled={name: (a, b, cool_s)}, tau_s=tau_s)
        start = segment_of(joined, name)[0]
        p = model.simulate(joined)[start - int(round(cool_s / d.dt)):start + w]
        # Σ (p[k + i] − y[i])² over i, for every shift k, without a window matrix
        p2 = np.convolve(p * p, np.ones(w), mode='valid')
        k = int(np.argmin(p2 - 2.0 * np.correlate(p, y, mode='valid')))
        leads.append((float(np.mean(np.abs(p[k:k + w] - y))), (a, b, k * d.dt)))
    best = min(miss for miss, _ in leads)
    return (at_rest,) + next((lead, miss) for miss, lead in leads if miss <= HEAT_TIE * best)


def cooling_starts(model: Any, records: list, tau_s: Optional[float] = None,
                   confirm: bool = True) -> dict:
    """
    Return {name: (duty_a, duty_b, cool_s)} for the records `model` sees start still cooling.

    A record that starts at zero duty and moves before any duty (`moves_unheated`) may have
    been begun while a wire cooled from an earlier run. It is led in so (`cooled_start`)
    when the model started at rest misses its start by more than WARM_MIN_MISS of its
    range; with `confirm`, only if the led-in model misses by less than WARM_ADVANTAGE
    times that. The model that judges a record is the one fitted without it when `model`
    has one (`ModelFit.folds`): a fit that has bent itself to the record's start at rest
    would place its lead-in off.
    """
    out = {}
    for name, d in records:
        heats = heat_options(d, records) if moves_unheated(d) else []
        if not heats:
            continue
        judge = getattr(model, 'folds', {}).get(name, model)
        at_rest, lead, miss = cooled_start(judge, name, d, heats, tau_s)
        if at_rest > WARM_MIN_MISS * d.span() and (not confirm or miss < WARM_ADVANTAGE * at_rest):
            out[name] = lead
    return out


def predict_cooled(model: Any, name: str, d: DynamicData, records: list,
                   tau_s: Optional[float] = None) -> np.ndarray:
    """
    Return `model`'s prediction of record `d`, led in still cooling as `model` sees it.

    The time into the cooling is the model's own (`cooled_start`): a model fitted without
    the record scores it as `compare` would, not from a lead-in chosen by another fit.
    """
    lead = cooled_start(model, name, d, heat_options(d, records), tau_s)[1]
    joined = join([(name, d)], cooled={name: lead}, tau_s=tau_s)
    a, b = segment_of(joined, name)
    return model.simulate(joined)[a:b]


def lead_ins(model: Any, records: list, confirm: bool = True) -> dict:
    """
    Return the `join` options `model` asks of the (name, DynamicData) records ({}: none).

    warm: the records that start warm by `model` (`warm_starts`, `confirm` passed on);
    cooled: those that start still cooling (`cooling_starts`); tau_s: the model's time
    constant when it is too slow for REST_GAP_S (`rest_gap_s`).
    """
    tau = model.values.get('tau_s')
    lead = {'tau_s': float(tau)} if tau is not None and rest_gap_s(tau) > REST_GAP_S else {}
    warm = warm_starts(model, records, lead.get('tau_s'), confirm)
    cooled = cooling_starts(model, records, lead.get('tau_s'), confirm)
    if warm:
        lead['warm'] = warm
    if cooled:
        lead['cooled'] = cooled
    if not warm and not cooled and len(records) == 1:
        lead.pop('tau_s', None)   # one record without a lead-in is not joined: no rest to set
    return lead
