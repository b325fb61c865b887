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
Leave one record out: each record scored by a model not fitted on it, one model fitted on all.

`sma-model fit A B C` without `--validate-on` runs this. A user with a handful of short
records of one rig (a step, a ramp, a square wave) cannot spare one: the record held out is
often the only one that shows a regime, e.g. the only one that cools. So every record is
held out in turn and predicted by the model fitted on the others, which is the honest
score, and the model written is fitted on every record, which is the model that predicts
the rig's next record best. The cost is one fit per record more.
"""
from dataclasses import replace
from typing import Any, Callable, List, Optional, Sequence, Tuple

import numpy as np

from .effects import is_builtin
from .engine import fit_model, ModelFit, part_scores, record_scores
from .leadins import predict_led
from .parallel import available_cores, imap_on_cores
from .records import join, segment_of, segment_view
from ..core.datakinds import DynamicData

# the role of a record in the per-record scores of a cross-validated fit
LEFT_OUT = 'left out'
# what a model file fitted this way says of its validation score
RULE = 'leave one record out'


def all_records(records: Sequence[Tuple[str, DynamicData]], notes: Optional[list] = None,
                **lead: Any) -> DynamicData:
    """
    Return the (name, DynamicData) records joined, every one of them training.

    lead: `records.join`'s lead_in and tau_s.
    """
    data = join(list(records), notes=notes, **lead)
    return replace(data, split=len(data))


def _fit_task(item: tuple) -> ModelFit:
    """Fit the (data, effects, kind, pinned) task of an (index, task) item (in a worker)."""
    data, effects, kind, pinned = item[1]
    return fit_model(data, effects=effects, kind=kind, pinned=pinned)


def fit_all(tasks: list, jobs: int = 0, progress: Optional[Callable] = None,
            label: str = 'fits') -> List[ModelFit]:
    """
    Return the fits of the (data, effects, kind, pinned) `tasks` in order (`engine.fit_model`).

    jobs: processes (0: every core); plug-in effects are fitted in this process, a worker
    would not have them. progress(done, total, label) after each fit.
    """
    poolable = all(is_builtin(e) for e in tasks[0][1])
    workers = min(jobs or available_cores(), len(tasks)) if poolable else 1
    items = list(enumerate(tasks))
    fits = [None] * len(tasks)
    for done, (item, fit) in enumerate(imap_on_cores(_fit_task, items, workers), 1):
        fits[item[0]] = fit
        if progress:
            progress(done, len(tasks), label)
    return fits


def cross_validate(records: Sequence[Tuple[str, DynamicData]], effects: tuple = (),
                   kind: Optional[str] = None, jobs: int = 0,
                   progress: Optional[Callable] = None,
                   **lead: Any) -> Tuple[DynamicData, ModelFit, list]:
    """
    Return (the joined records, the model fitted on all of them, the per-record scores).

    Record i's left-out prediction ŷ_i comes from the model fitted on every record but i
    (each simulated from its own rest, `records.join`; one that does not start at rest,
    led in as that model sees it, `leadins.predict_led`). The fit returned is the one on all
    records (`folds` holds the others): its `train` scores are its own, its `validation`
    scores pool the left-out predictions of every record (NRMSE over the whole set's
    measured range, as any held-out score). Per record: {'data', 'role': 'left out',
    'scores': {'all': ŷ_i's scores, 'train': the returned model's}}. jobs: processes for the
    fits (0: every core; plug-in effects are fitted in this process, a worker would not have
    them). lead: `records.join`'s lead_in and tau_s.
    """
    if len(records) < 2:
        raise ValueError('leaving one record out needs two records or more')
    names = [name for name, _ in records]
    folds = [join(list(records), held_out=(name,), **lead) for name in names]
    data = all_records(records, **lead)
    effects = tuple(effects)
    fits = fit_all([(d, effects, kind, None) for d in folds + [data]], jobs, progress)
    final = fits[-1]
    left_out = np.full(len(data), np.nan)
    led = lead.get('lead_in', {})
    for name, fold, fit in zip(names, folds, fits):
        a, b = segment_of(fold, name)
        start, stop = segment_of(data, name)
        left_out[start:stop] = (predict_led(fit, name, segment_view(data, start, stop),
                                            records, lead)
                                if name in led else fit.prediction[a:b])
    final.folds = dict(zip(names, fits[:-1]))
    final.validation = part_scores(data, left_out, data.scored_mask())
    final.rig['validation_rule'] = RULE
    rows = record_scores(data, left_out, role=LEFT_OUT)
    for row, fitted in zip(rows, record_scores(data, final.prediction)):
        row['scores']['train'] = fitted['scores']['all']
    return data, final, rows
