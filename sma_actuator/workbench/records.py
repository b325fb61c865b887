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
Join several dynamic records of one rig into one record set.

Each record is simulated from its own initial state: the records are joined with a rest
gap of zero duty between them, long enough for the model's wires to cool to ambient
(`rest_gap_s`: REST_GAP_S, or REST_TAUS time constants of a slower wire), so every record
starts at rest; the gaps are not scored (`DynamicData.scored`)
and not regressed. A record that does not start at rest (a log begun mid-run with the wires
warm, or right after a run with a wire still cooling: `leadins`) is led in by duties held
after the rest, then its first duties as long as its start asks.
Records at another sample rate are resampled to the first record's rate (duties held,
position and ambient interpolated). Held-out records go last, so the
training window is one prefix (`DynamicData.split`).

Default train/validation rule: with one record, the first 70 % of time trains and the rest
validates; with two or more, the last record given is held out (train on the others);
`validate` names the held-out records instead.
"""
from typing import Any, Optional, Tuple

import numpy as np
from scipy.ndimage import uniform_filter1d

from .formats import DataError, MIN_SAMPLES
from .limits import MAX_FIT_RATE_HZ
from .timegrid import resample_columns
from ..core.datakinds import DynamicData, SAMPLING_TOLERANCE
from ..core.play_grids import flexinol_loop_ratio
from ..core.scoring import noise_rms

# rest between joined records [s]: e^-6 of the excess temperature is left at a thermal time
# constant of 10 s
REST_GAP_S = 60.0
# ... or this many thermal time constants of a model whose τ is longer than REST_GAP_S / 6
REST_TAUS = 6.0
# rest at the start of a record used for its sensor zero [s] (or until the duty first rises)
ZERO_WINDOW_S = 1.0
# a training set whose measured position never reverses by this share of its range has not
# shown a wire cooling back through its transformation (`loop_prior`)
MIN_REVERSAL = 0.5
# moving mean over the measured position before looking for reversals [s] (sensor noise)
REVERSAL_SMOOTH_S = 0.2
# a record's start: while its duties hold their first values, at most this long [s]
START_WINDOW_S = 5.0
# a record that starts at zero duty moves (a wire still cooling) when the means of its
# start's first and last MOTION_MEAN_S [s] differ by more than MOTION_SHARE of its range
# and by more than MOTION_NOISE standard errors of that difference (a record that barely
# moves has a range of a few noise steps)
MOTION_MEAN_S = 0.2
MOTION_SHARE = 0.02
MOTION_NOISE = 4.0
# a record that starts at rest further than this share of the measured range from a model's
# rest was read by an untared sensor: the rests of one rig's runs scatter by about 1 % (the
# slider's friction; the three shared records: 0.16 mm of 17 mm), a sensor zero by any amount
UNTARED_SHARE = 0.02


def start_rest(data: DynamicData) -> int:
    """
    Return the number of samples of one record's start rest.

    The first ZERO_WINDOW_S, cut where a duty first exceeds zero (at least the first
    sample).
    """
    return 1 if starts_heated(data) else max(1, start_window(data, ZERO_WINDOW_S))


def start_window(d: DynamicData, window_s: float = START_WINDOW_S) -> int:
    """Return the samples of a record's start: while its duties hold, at most window_s [s]."""
    n = min(len(d), int(round(window_s / d.dt)))
    changed = np.flatnonzero((d.duty_a != d.duty_a[0]) | (d.duty_b != d.duty_b[0]))
    return min(n, int(changed[0])) if changed.size else n


def starts_heated(d: DynamicData) -> bool:
    """Return whether a record's first sample has a duty on."""
    return bool(d.duty_a[0] > 0 or d.duty_b[0] > 0)


def moves_unheated(d: DynamicData) -> bool:
    """
    Return whether a record starts at zero duty and moves before any duty comes on.

    A wire at rest holds still at zero duty; one still cooling from an earlier run does
    not. The move is |mean of the start's last MOTION_MEAN_S − mean of its first| over
    `start_window` (k samples each), against MOTION_SHARE of the record's range and
    MOTION_NOISE σ √(2 / k), σ the record's measurement noise (`noise_rms`).
    """
    if starts_heated(d):
        return False
    w, k = start_window(d), max(1, int(round(MOTION_MEAN_S / d.dt)))
    if w < 2 * k:
        return False
    y = d.position[:w]
    least = max(MOTION_SHARE * d.span(), MOTION_NOISE * noise_rms(d.position) * np.sqrt(2 / k))
    return abs(float(np.mean(y[-k:]) - np.mean(y[:k]))) > least


def starts_at_rest(d: DynamicData) -> bool:
    """Return whether a record shows a rest at its start: zero duty, not moving."""
    return not (starts_heated(d) or moves_unheated(d))


def record_zero(data: DynamicData) -> float:
    """Return the sensor zero of one record: its mean position at rest (`start_rest`)."""
    return float(np.mean(data.position[:start_rest(data)]))


def start_offsets(data: DynamicData, prediction: np.ndarray) -> dict:
    """
    Return {record: mean measured − predicted position over its start rest} [position unit].

    A model without `sensor_zero` predicts where the sensor read at rest in training; a
    record whose sensor was not tared starts off by this much.
    """
    out = {}
    for name, a, b in data.segments or (('DATA', 0, len(data)),):
        n = start_rest(segment_view(data, a, b))
        out[name] = float(np.mean(data.position[a:a + n] - prediction[a:a + n]))
    return out


def start_rests(records: list) -> dict:
    """Return {name: sensor zero} of the (name, DynamicData) records that start at rest."""
    return {name: record_zero(d) for name, d in records if starts_at_rest(d)}


def untared_offsets(data: DynamicData, prediction: np.ndarray,
                    share: float = UNTARED_SHARE, travel: float = 0.0) -> dict:
    """
    Return {record: start offset} of the records read by an untared sensor [position unit].

    Those that start at rest (`starts_at_rest`) with a `start_offsets` entry larger than
    `share` of the measured range (`DynamicData.span`), or of the model's `travel` [position
    unit] when that is larger (records that barely move: a rest scatters with the rig's
    stroke, not with theirs).
    """
    offsets = start_offsets(data, prediction)
    limit = share * max(data.span(), travel)
    return {name: offsets[name] for name, a, b in data.segments or (('DATA', 0, len(data)),)
            if abs(offsets[name]) > limit and starts_at_rest(segment_view(data, a, b))}


def referred_to_rest(data: DynamicData, prediction: np.ndarray, offsets: dict) -> np.ndarray:
    """Return `prediction` with each record of `offsets` moved by its offset: ŷ + z_k − z."""
    out = np.array(prediction, float)
    for name, a, b in data.segments or (('DATA', 0, len(data)),):
        out[a:b] += offsets.get(name, 0.0)
    return out


def reversal(data: DynamicData, n_train: Optional[int] = None) -> float:
    """
    Return the largest reversal of the measured position in the training records.

    Per record (training samples only, smoothed over REVERSAL_SMOOTH_S): the smaller of its
    largest rise from a running minimum and its largest fall from a running maximum, i.e.
    how far it went back after going out; the largest over the records, as a share of the
    range of the measured position over all training samples. A record that heats and holds
    scores its creep only; one that heats and cools to rest scores about 1.
    """
    n_train = n_train or data.default_split().start
    keep = data.scored_mask()
    span = float(np.ptp(data.position[:n_train][keep[:n_train]]))
    k = max(1, int(round(REVERSAL_SMOOTH_S / data.dt)))
    best = 0.0
    for _, a, b in data.segments or (('', 0, len(data)),):
        y = data.position[a:min(b, n_train)]
        if len(y) < k:
            continue
        y = np.convolve(y, np.ones(k) / k, mode='valid')
        rise = np.max(y - np.minimum.accumulate(y))
        fall = np.max(np.maximum.accumulate(y) - y)
        best = max(best, float(min(rise, fall)))
    return best / span if span > 0 else 0.0


def loop_prior(data: DynamicData, n_train: Optional[int] = None) -> Optional[float]:
    """
    Return the loop ratio β to tie the cooling branch with, or None when the data shows it.

    Training records that never reverse by MIN_REVERSAL of their range (heat and hold,
    ramps up) leave the descending branch unidentified: the datasheet loop's proportions
    (`core.play_grids.flexinol_loop_ratio`, `tie_loop_width`) stand in for it.
    """
    return flexinol_loop_ratio() if reversal(data, n_train) < MIN_REVERSAL else None


def _resample(data: DynamicData, dt: float) -> DynamicData:
    """
    Return `data` on a grid of step dt [s]: duties held, other signals interpolated.

    A new sample is measured (`DynamicData.scored`) when the two it lies between are.
    """
    cols = resample_columns({'time': data.time, 'duty_a': data.duty_a, 'duty_b': data.duty_b,
                             'position': data.position, 'ambient': data.ambient,
                             'setpoint': data.setpoint, 'scored': _share(data.scored)}, dt)
    return DynamicData(cols['time'], cols['duty_a'], cols['duty_b'], cols['position'],
                       ambient=cols['ambient'], setpoint=cols['setpoint'],
                       position_unit=data.position_unit, layout=data.layout,
                       scored=_all_of(cols['scored']))


def _share(scored: Optional[np.ndarray]) -> Optional[np.ndarray]:
    """Return a scored mask as 1.0 / 0.0 (to average or interpolate), None as None."""
    return None if scored is None else np.asarray(scored, float)


def _all_of(share: Optional[np.ndarray]) -> Optional[np.ndarray]:
    """Return where an averaged or interpolated `_share` is whole: every sample it spans."""
    return None if share is None else partly_measured(share > 1.0 - 1e-9)


def partly_measured(scored: Optional[np.ndarray]) -> Optional[np.ndarray]:
    """Return a scored mask that leaves samples out, else None (every sample measured)."""
    return None if scored is None or np.all(scored) else np.asarray(scored, bool)


def decimate(data: DynamicData, factor: int) -> DynamicData:
    """
    Return `data` at 1/factor of its rate; sample k of the result is at time t[k M], M = factor.

    A duty is the one in effect until the next sample, so the new duty is the mean over
    [t[k M], t[(k + 1) M]): the same heating energy (eq. 7's R i² is linear in the PWM
    duty). Position, ambient and setpoint are the means of the M samples centred on t[k M]:
    measurement noise falls by √M and the reading does not lag; such a mean is measured
    (`DynamicData.scored`) when all M are. A last partial block is dropped (under M samples).
    """
    m = int(factor)
    n = len(data) // m
    keep = np.arange(n) * m

    def block_mean(x: np.ndarray) -> np.ndarray:
        return x[:n * m].reshape(n, m).mean(axis=1)

    def centred_mean(x: Optional[np.ndarray]) -> Optional[np.ndarray]:
        return None if x is None else uniform_filter1d(x, m, mode='nearest')[keep]
    return DynamicData(data.time[keep], block_mean(data.duty_a), block_mean(data.duty_b),
                       centred_mean(data.position), ambient=centred_mean(data.ambient),
                       setpoint=centred_mean(data.setpoint), position_unit=data.position_unit,
                       layout=data.layout, scored=_all_of(centred_mean(_share(data.scored))))


def at_fit_rate(data: Any, max_rate_hz: float = MAX_FIT_RATE_HZ) -> Tuple[Any, Optional[str]]:
    """
    Return (`data` at no more than `max_rate_hz` [Hz], a note saying what was done or None).

    A dynamic record sampled faster is decimated (`decimate`) by the smallest whole factor
    that brings it to `max_rate_hz` or below; slower records, records too short to keep
    MIN_SAMPLES samples (small anyway) and static curves are returned as they are.
    """
    if getattr(data, 'kind', None) != DynamicData.kind or 1.0 / data.dt <= max_rate_hz * (
            1.0 + SAMPLING_TOLERANCE):
        return data, None
    factor = int(np.ceil(1.0 / (data.dt * max_rate_hz) - SAMPLING_TOLERANCE))
    if len(data) // factor < MIN_SAMPLES:
        return data, None
    slow = decimate(data, factor)
    return slow, (f'decimated from {1.0 / data.dt:.4g} Hz to {1.0 / slow.dt:.4g} Hz (means of '
                  f'{factor} samples; --max-rate {max_rate_hz:g} Hz)')


def check_compatible(records: list) -> None:
    """
    Raise `DataError` unless the (name, DynamicData) records can be fitted together.

    They must share the position unit, the rig layout and the optional columns
    (ambient, setpoint).
    """
    name0, d0 = records[0]
    for name, d in records[1:]:
        if d.position_unit != d0.position_unit:
            raise DataError(f'{name}: position in {d.position_unit}, but {name0} has it in '
                            f'{d0.position_unit} (records fitted together need one unit)')
        if d.layout != d0.layout:
            raise DataError(f'{name}: a {d.layout} rig, but {name0} is {d0.layout} (duty_b '
                            'used in one record only; records fitted together need one layout, '
                            'or give --layout)')
        for col in ('ambient', 'setpoint'):
            if (getattr(d, col) is None) != (getattr(d0, col) is None):
                has, lacks = (name, name0) if getattr(d, col) is not None else (name0, name)
                raise DataError(f'{lacks}: has no {col} column but {has} has one (records '
                                'fitted together need the same columns)')


def _lead_in(d: DynamicData, n: int, before: Optional[tuple]) -> tuple:
    """
    Return the unscored lead-in of record `d`: n samples at rest, then as `before` says.

    before: None (rest only) or (duty_a, duty_b, first_s): those duties held n samples, then
    the record's first duties for first_s [s], so the record starts where they left the
    wires whatever the record before it left: (0, 0, long) is the steady state of its
    first duties (a log begun mid-run), (heat_a, heat_b, s) with zero first duties a wire
    cooling for s after a run.
    """
    def first(x: Optional[np.ndarray], k: int) -> Optional[np.ndarray]:
        return None if x is None else np.full(k, x[0])
    phases = () if before is None else (
        (before[0], before[1], n), (d.duty_a[0], d.duty_b[0], int(round(before[2] / d.dt))))
    k = n + sum(p[2] for p in phases)
    duty_a, duty_b = np.zeros(k), np.zeros(k)
    at = n
    for a, b, m in phases:
        duty_a[at:at + m], duty_b[at:at + m] = a, b
        at += m
    return (duty_a, duty_b, first(d.position, k), first(d.ambient, k), first(d.setpoint, k),
            np.zeros(k, bool))


def rest_gap_s(tau_s: Optional[float] = None) -> float:
    """Return the rest between joined records [s]: REST_GAP_S, or REST_TAUS × a longer τ."""
    return REST_GAP_S if tau_s is None else max(REST_GAP_S, REST_TAUS * float(tau_s))


def join(records: list, held_out: tuple = (), notes: Optional[list] = None,
         lead_in: Optional[dict] = None, tau_s: Optional[float] = None) -> DynamicData:
    """
    Return one `DynamicData` holding the (name, DynamicData) records, joined at rest.

    held_out: names of the records to validate on (they go last). With one record and none
    held out, that record is returned as it is (the time split applies). notes: a list
    that receives one line per resampled record. lead_in: {name: (duty_a, duty_b,
    first_s)}: records that do not start at rest, led in by those duties held as long as
    the rest, then their first duties for first_s [s] (`_lead_in`, `leadins.lead_ins`).
    tau_s: a model's thermal time constant [s], which sets the rest (`rest_gap_s`).
    """
    lead_in = lead_in or {}
    if len(records) == 1 and not held_out and not lead_in:
        name, d = records[0]
        return DynamicData(d.time, d.duty_a, d.duty_b, d.position, d.ambient, d.setpoint,
                           d.position_unit, d.layout, ((name, 0, len(d)),), d.scored, None)
    check_compatible(records)
    dt = records[0][1].dt
    order = ([r for r in records if r[0] not in held_out]
             + [r for r in records if r[0] in held_out])
    if not any(r[0] not in held_out for r in order):
        raise DataError('every record is held out for validation; keep at least one to fit on')
    parts, segments, split, at = [], [], None, 0
    gap = int(round(rest_gap_s(tau_s) / dt))
    for i, (name, d) in enumerate(order):
        if abs(d.dt - dt) > SAMPLING_TOLERANCE * dt:
            if notes is not None:
                notes.append(f'{name}: resampled from {1.0 / d.dt:.4g} Hz to {1.0 / dt:.4g} Hz '
                             f'(the rate of {records[0][0]})')
            d = _resample(d, dt)
        if split is None and name in held_out:
            split = at
        if i or name in lead_in:
            parts.append(_lead_in(d, gap, lead_in.get(name)))
            at += len(parts[-1][0])
        parts.append((d.duty_a, d.duty_b, d.position, d.ambient, d.setpoint,
                      d.scored_mask()))
        segments.append((name, at, at + len(d)))
        at += len(d)
    cols = [np.concatenate([p[k] for p in parts]) if parts[0][k] is not None else None
            for k in range(6)]
    d0 = records[0][1]
    return DynamicData(np.arange(at) * dt, cols[0], cols[1], cols[2], cols[3], cols[4],
                       d0.position_unit, d0.layout, tuple(segments), cols[5], split)


def segment_of(data: DynamicData, name: str) -> tuple:
    """Return the (start, stop) sample range of record `name` in joined `data`."""
    for n, a, b in data.segments:
        if n == name:
            return a, b
    raise KeyError(name)


def zeros(data: DynamicData, fallback: Optional[float] = None) -> np.ndarray:
    """
    Return the per-sample sensor zero of joined `data` (each record's start rest).

    A record that shows no rest at its start (begun with a duty on, or with a wire still
    cooling: `starts_at_rest`) takes the median zero of the records that do, else
    `fallback` (a model's training records' median zero), else its own first reading.
    """
    z = np.zeros(len(data))
    segs = data.segments or (('', 0, len(data)),)
    views = [segment_view(data, a, b) for _, a, b in segs]
    rests = [starts_at_rest(v) for v in views]
    owns = [record_zero(v) for v in views]
    rested = [own for own, rest in zip(owns, rests) if rest]
    other = float(np.median(rested)) if rested else fallback
    for i, ((_, a, _), own, rest) in enumerate(zip(segs, owns, rests)):
        stop = segs[i + 1][1] if i + 1 < len(segs) else len(data)
        z[a:stop] = own if rest or other is None else other
    return z


def record_strokes(data: DynamicData, prediction: np.ndarray,
                   n_train: Optional[int] = None) -> dict:
    """
    Return each record's stroke relative to the median record's, {name: ρ_k}.

    ρ_k = (Σ p_k m_k / Σ p_k²) / median over the training records of the same ratio, with
    p_k the departure of a (pooled) model's `prediction` from its value at the record's
    first sample and m_k the measured departure from the record's start rest
    (`record_zero`), over the record's samples: the least-squares factor by which the
    record's contraction differs from the model's, referred to the median training record.
    Held-out records (at or after n_train, default `data.split`) get ρ = 1: their stroke is
    unknown until they are measured, so they are predicted with the median stroke.
    """
    n_train = n_train or data.split or len(data)
    keep = data.scored_mask()
    raw = {}
    for name, a, b in data.segments or (('DATA', 0, len(data)),):
        if a >= n_train:
            continue
        k = keep[a:b]
        p = (prediction[a:b] - prediction[a])[k]
        m = (data.position[a:b] - record_zero(segment_view(data, a, b)))[k]
        den = float(np.sum(p * p))
        raw[name] = float(np.sum(p * m) / den) if den > 0 else 1.0
    ref = float(np.median(list(raw.values()))) if raw else 1.0
    return {name: (raw[name] / ref if name in raw and ref > 0 else 1.0)
            for name, _, _ in data.segments or (('DATA', 0, len(data)),)}


def stroke_scale(data: DynamicData, strokes: dict) -> np.ndarray:
    """
    Return the per-sample stroke factor of joined `data` (each record's ρ, 1 on its gaps).

    `strokes`: {name: ρ} (`record_strokes`); from a record's first sample to the next
    record's, as `zeros` (the gaps are neither regressed nor scored).
    """
    s = np.ones(len(data))
    segs = data.segments or (('DATA', 0, len(data)),)
    for i, (name, a, _) in enumerate(segs):
        stop = segs[i + 1][1] if i + 1 < len(segs) else len(data)
        s[a:stop] = strokes.get(name, 1.0)
    return s


def segment_view(data: DynamicData, a: int, b: int) -> DynamicData:
    """Return samples [a, b) of joined `data` as a plain `DynamicData` (one record)."""
    def cut(x: Optional[np.ndarray]) -> Optional[np.ndarray]:
        return None if x is None else x[a:b]
    return DynamicData(data.time[a:b], data.duty_a[a:b], data.duty_b[a:b], data.position[a:b],
                       cut(data.ambient), cut(data.setpoint), data.position_unit, data.layout,
                       scored=partly_measured(cut(data.scored)))
