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
Bag reader fuzz: mutated recorder bags end as correct data, exact loss report or a BagError.

Issue 13 item 5/6. The bags come from the recorder's writer (`write_demo_run`, several
compressions, chunk sizes and a split bag); each case truncates, flips bits, zeroes a range of
an .mcap file or edits ``metadata.yaml``. Outcomes:

- correct: the messages equal the original ones;
- recovered: a subset of the original messages, and the reports' lost message count equals
  exactly the number missing;
- error: a `BagError` (the package's error, naming the file).

Anything else (another exception, wrong or incomplete data without an exact report, a case
running past its time bound) is a failure.
"""
import collections
import os
import random

import numpy as np
import pytest

from sma_actuator.bag.arrays import load_run
from sma_actuator.bag.errors import BagError
from sma_actuator.bag.reader import BagReader
from support.bag_fuzz import (CaseTimeout, make_sources, MCAP_KINDS, mutate_bag, SOURCES,
                              time_limit)

SEED = 1313
CASES = int(os.environ.get('FUZZ_CASES', 2200))
CASE_TIME_LIMIT_S = 10.0
LOAD_RUN_EVERY = 10  # load_run (the workbench path) on every 10th case, BagReader on all


def _messages(reader):
    return sorted((m.topic, m.log_time_ns, m.publish_time_ns, bytes(m.data))
                  for m in reader.messages())


def _read(path):
    reader = BagReader(path)
    return _messages(reader), reader.message_count, reader.recoveries


def _classify(path, original, run, check_arrays):
    """Return (outcome, detail); outcome in correct/recovered/error/failure."""
    try:
        with time_limit(CASE_TIME_LIMIT_S):
            got, count, reports = _read(path)
            arrays = None
            if check_arrays:
                try:
                    arrays = load_run(path)
                except BagError as err:
                    arrays = err
    except BagError as err:
        return 'error', str(err)
    except CaseTimeout as err:
        return 'failure', f'hang: {err}'
    except Exception as err:  # noqa: BLE001 - any other exception is what the fuzz looks for
        return 'failure', f'{type(err).__name__}: {err}'
    lost = len(original) - len(got)
    extra = collections.Counter(got) - collections.Counter(original)
    if extra:
        return 'failure', f'{sum(extra.values())} messages not in the original'
    if count != len(got):
        return 'failure', f'message_count {count} but {len(got)} messages read'
    if isinstance(arrays, dict):
        if lost == 0 and not all(np.array_equal(arrays[k], run[k], equal_nan=True)
                                 for k in run):
            return 'failure', 'load_run arrays differ from the original'
        if len(arrays['time']) > len(run['time']):
            return 'failure', f'load_run returned {len(arrays["time"])} samples, ' \
                              f'original {len(run["time"])}'
    if lost == 0:
        return 'correct', ''
    reported = sum(r.lost_messages for r in reports)
    if reported != lost:
        return 'failure', (f'{lost} of {len(original)} messages missing, reports say '
                           f'{reported}: {"; ".join(str(r) for r in reports) or "no report"}')
    return 'recovered', ''


@pytest.mark.slow
def test_mutated_bags_end_as_correct_recovered_or_bag_error(tmp_path):
    sources = make_sources(tmp_path / 'sources')
    originals = {}
    for name, path in sources.items():
        originals[name] = (_read(path)[0], load_run(path))
    rng = random.Random(SEED)
    names = sorted(sources)
    outcomes = collections.Counter()
    by_kind = collections.defaultdict(collections.Counter)
    failures = []
    kinds = MCAP_KINDS + ('bitflip', 'zero', 'metadata')
    for case in range(CASES):
        name = names[case % len(names)]
        kind = kinds[rng.randrange(len(kinds))]
        other = sources[names[(case + 1) % len(names)]]
        target = tmp_path / 'case' / name
        what = mutate_bag(rng, sources[name], target, other, kind)
        outcome, detail = _classify(target, *originals[name],
                                    check_arrays=case % LOAD_RUN_EVERY == 0)
        outcomes[outcome] += 1
        by_kind[kind][outcome] += 1
        if outcome == 'failure':
            failures.append(f'case {case} ({name}, {what}): {detail}')
    names_out = ('correct', 'recovered', 'error', 'failure')
    counts = ', '.join(f'{k} {outcomes[k]}' for k in names_out)
    kinds_text = '; '.join(f'{k}: {dict(v)}' for k, v in sorted(by_kind.items()))
    summary = f'{CASES} mutated bags: {counts}; by mutation: {kinds_text}'
    print(summary)
    for line in failures[:40]:
        print('  ' + line[:400])
    assert not failures, summary + '\n' + '\n'.join(f[:300] for f in failures[:15])
    assert len(SOURCES) == len(sources)
