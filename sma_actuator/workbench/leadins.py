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
and the wires warm; one begun right after an earlier run starts at zero duty with a wire
still cooling. Both are the record's first duties having been on for a while after other
duties: zero for a warm start, a heat for a cooling one. `start_lead` finds how long, by
the model's prediction of the record's start; `lead_ins` gives `records.join` the lead-in
each record asks of a model, so the model starts where the wires were.
"""
from typing import Any, Callable, Optional, Tuple

import numpy as np

from .engine import part_scores
from .records import (join, moves_unheated, REST_GAP_S, rest_gap_s, segment_of,
                      start_window, starts_heated)
from ..core.datakinds import DynamicData

# a record is led in when the start at rest misses its start by more than this share of
# its range (mean |measured − predicted|) ...
LEAD_MIN_MISS = 0.02
# ... and (`confirm`) the led-in start misses by less than this share of that
LEAD_ADVANTAGE = 0.5
# duties tried for a cooling record when no record of the set heats: geometric, up to full
UNKNOWN_HEATS = np.geomspace(0.02, 1.0, 16)
# lead-ins whose RMS error over the start is within this factor of the best match it alike
LEAD_TIE = 1.1
# a refit with lead-ins (records that do not start at rest, a longer rest) is kept only if
# its RMS error over every measured sample is below this share of the first fit's
LEAD_IN_GAIN = 0.9


def heat_options(d: DynamicData, records: list) -> list:
    """
    Return the (duty_a, duty_b) a cooling record's wire may have been heated by.

    Each wire alone at the highest duty the record gives it, or, for a record that never
    heats, the highest the record set gives it (what the rig's runs use), or else at each
    of UNKNOWN_HEATS (`start_lead` takes the lowest that matches). Lowest duty first.
    """
    def peak(column: str, source: list) -> float:
        return max(float(np.max(getattr(r, column))) for r in source)
    wires = ('duty_a',) if d.layout == 'single' else ('duty_a', 'duty_b')
    others = [r for _, r in records]
    peaks = [peak(w, [d]) or peak(w, others) for w in wires]
    duties = [(w, p) for w, p in zip(wires, peaks) if p > 0] or [
        (w, float(p)) for p in UNKNOWN_HEATS for w in wires]
    return sorted([(p, 0.0) if w == 'duty_a' else (0.0, p) for w, p in duties], key=sum)


def befores(d: DynamicData, records: list) -> list:
    """
    Return the (duty_a, duty_b) that may have held before a record's first duties.

    Rest, for a record that starts with a duty on (a log begun mid-run); a heat
    (`heat_options`) for one that starts at zero duty and moves (a wire still cooling);
    none for one that starts at rest.
    """
    if starts_heated(d):
        return [(0.0, 0.0)]
    return heat_options(d, records) if moves_unheated(d) else []


def start_lead(model: Any, name: str, d: DynamicData, records: list,
               tau_s: Optional[float] = None) -> Optional[tuple]:
    """
    Return (miss at rest, lead-in, its miss) for record `d`, or None if it starts at rest.

    The model holds each of `befores` for the rest gap, then the record's first duties for
    as long again; the lead-in (duty_a, duty_b, first_s [s]) is the duties before and the
    time into the first duties whose prediction matches the record's `start_window`
    (RMS error over every shift: the duties hold there, so the prediction just goes on;
    first_s 0 is a start at rest, the whole gap their steady state). Lead-ins within
    LEAD_TIE of the best match alike, and a start that barely changes cannot tell them
    apart. A warm start takes the longest time of those (the wires nearest the steady state
    of their duties); a cooling one the lowest heat, at its best time (the lowest heat that
    explains a start that shows no fall yet falls soonest: a longer time too would make it
    fall sooner still). Misses are mean |measured − predicted| over the start [position
    unit].
    """
    options = befores(d, records)
    if not options:
        return None
    w = start_window(d)
    y = d.position[:w]
    at_rest = float(np.mean(np.abs(y - model.simulate(join([(name, d)]))[:w])))
    gap_s = rest_gap_s(tau_s)
    leads = []
    for a, b in options:
        joined = join([(name, d)], lead_in={name: (a, b, gap_s)}, tau_s=tau_s)
        start = segment_of(joined, name)[0]
        p = model.simulate(joined)[start - int(round(gap_s / d.dt)):start + w]
        rms, k = _best_shift(p, y, longest=starts_heated(d))
        leads.append((rms, (a, b, k * d.dt), float(np.mean(np.abs(p[k:k + w] - y)))))
    best = min(rms for rms, _, _ in leads)
    return (at_rest,) + next((lead, miss) for rms, lead, miss in leads if rms <= LEAD_TIE * best)


def _best_shift(p: np.ndarray, y: np.ndarray, longest: bool) -> tuple:
    """
    Return (least RMS error, shift k) of p[k:k + len(y)] against y over every shift k.

    longest: the last shift within LEAD_TIE of the least error, else the least.
    """
    w = len(y)
    # Σ (p[k + i] − y[i])² over i for every k, without a window matrix
    sse = (np.convolve(p * p, np.ones(w), mode='valid')
           - 2.0 * np.correlate(p, y, mode='valid') + float(np.dot(y, y)))
    rms = np.sqrt(np.maximum(sse, 0.0) / w)
    k = np.flatnonzero(rms <= LEAD_TIE * rms.min())[-1] if longest else np.argmin(rms)
    return float(rms.min()), int(k)


def started(model: Any, records: list, tau_s: Optional[float] = None,
            confirm: bool = True) -> dict:
    """
    Return {name: lead-in} for the (name, DynamicData) records that do not start at rest.

    A record is led in (`start_lead`) when the model started at rest misses its start by
    more than LEAD_MIN_MISS of its range; with `confirm`, only if the led-in model misses
    by less than LEAD_ADVANTAGE times that. The model that judges a record is the one
    fitted without it when `model` has one (`ModelFit.folds`): a fit that has bent itself
    to the record's start at rest would place its lead-in off.
    """
    out = {}
    for name, d in records:
        judge = getattr(model, 'folds', {}).get(name, model)
        found = start_lead(judge, name, d, records, tau_s)
        if found is None:
            continue
        at_rest, lead, miss = found
        if at_rest > LEAD_MIN_MISS * d.span() and (
                not confirm or miss < LEAD_ADVANTAGE * at_rest):
            out[name] = lead
    return out


def predict_led(model: Any, name: str, d: DynamicData, records: list,
                lead: dict) -> np.ndarray:
    """
    Return `model`'s prediction of record `name` held out, led in as `model` sees its start.

    d: the record as joined (at the set's rate); lead: `records.join`'s options for the
    set. The lead-in is the model's own (`start_lead`): a model fitted without the record
    scores it as `compare` would, not from a lead-in chosen by another fit. The whole set
    is simulated, so the record's sensor zero comes from the set (`records.zeros`).
    """
    tau_s = lead.get('tau_s')
    led = dict(lead.get('lead_in', {}))
    found = start_lead(model, name, d, records, tau_s)
    led.pop(name, None)
    if found:
        led[name] = found[1]
    joined = join(list(records), held_out=(name,), lead_in=led, tau_s=tau_s)
    a, b = segment_of(joined, name)
    return model.simulate(joined)[a:b]


def lead_ins(model: Any, records: list, confirm: bool = True) -> dict:
    """
    Return the `join` options `model` asks of the (name, DynamicData) records ({}: none).

    lead_in: the records that do not start at rest (`started`, `confirm` passed on);
    tau_s: the model's time constant when it is too slow for REST_GAP_S (`rest_gap_s`).
    """
    tau = model.values.get('tau_s')
    lead = {'tau_s': float(tau)} if tau is not None and rest_gap_s(tau) > REST_GAP_S else {}
    led = started(model, records, lead.get('tau_s'), confirm)
    if led:
        lead['lead_in'] = led
    elif len(records) == 1:   # one record without a lead-in is not joined: no rest to set
        lead.pop('tau_s', None)
    return lead


def refit_led(fit: Any, data: DynamicData, records: list,
              refit: Callable[..., tuple]) -> Tuple[Optional[tuple], dict]:
    """
    Return (refit(**lead), lead) if the first `fit` of `data` asks for lead-ins, else (None, {}).

    lead: `lead_ins` of the (name, DynamicData) `records`, unconfirmed: the first fit has
    bent itself to their starts. refit(**lead) returns (its joined data, its fit, ...) and
    is kept only if its RMS error over every measured sample (training and held out: the
    lead-ins change how each record starts) is below LEAD_IN_GAIN times the first fit's.
    """
    def rmse(f: Any, d: DynamicData) -> float:
        return part_scores(d, f.prediction, d.scored_mask())['rmse']
    lead = lead_ins(fit, records, confirm=False) if records[0][1].joinable else {}
    led = refit(**lead) if lead else None
    if led is None or rmse(led[1], led[0]) >= LEAD_IN_GAIN * rmse(fit, data):
        return None, {}
    return led, lead
