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
Benchmark: `sma-model batch` records per minute on 1 and 2 Dask workers, against a loop.

Makes N records with the package's own plant model under the controller's identification
excitation (half with a hidden 0.3 s delay, half without), then times in one run, side by side:

* loop:      load, fit and diagnose each record in this process, one after the other
             (what a user's for-loop over `sma-model diagnose --jobs 1` does);
* batch 1/2: `batch.run_batch` on a LocalCluster of 1 and of 2 single-threaded workers
             (no reports in either, so both do the same numerical work).

Also prints the per-record CPU time and the peak resident memory of a worker, the figures
docs/scale.md plans a large cluster with.

    .venv/bin/python benchmarks/bench_batch.py [--records 8] [--minutes 4] [--rate 20]
"""
import argparse
from pathlib import Path
import tempfile
import time

import numpy as np
from sma_actuator.core.actuator import ActuatorParams, simulate
from sma_actuator.core.excitation import multilevel
from sma_actuator.workbench import batch
from sma_actuator.workbench.data import check_excitation, load_data
from sma_actuator.workbench.diagnosis import diagnose
from sma_actuator.workbench.engine import fit_model


COLUMNS = ('time', 'duty_a', 'duty_b', 'position')


def make_records(directory, n, minutes, rate_hz):
    """Write n CSV records of the plant model; every second one has a 0.3 s delay."""
    paths, dt = [], 1.0 / rate_hz
    for i in range(n):
        effect = 'delay' if i % 2 else 'none'
        duty_a, duty_b = multilevel(60.0 * minutes, dt, seed=i)
        params = ActuatorParams(delay_s=0.3 if i % 2 else 0.0)
        position = simulate(params, duty_a, duty_b, dt).position_rad
        position += np.random.default_rng(i).normal(0.0, 0.002, len(position))
        path = Path(directory) / f'{effect}_{i:03d}.csv'
        np.savetxt(path, np.column_stack([np.arange(len(position)) * dt, duty_a, duty_b,
                                          position]), delimiter=',',
                   header=','.join(COLUMNS), comments='', fmt='%.6g')
        paths.append(path)
    return paths


def time_loop(paths, candidates):
    """Seconds for the plain loop; returns (seconds, named effects)."""
    start = time.perf_counter()
    named = []
    for path in paths:
        data = load_data(path)
        check_excitation(data, path)
        named.append(diagnose(data, base=fit_model(data), candidates=candidates,
                              jobs=1).missing_effect)
    return time.perf_counter() - start, named


def worker_peak_rss(client):
    """Largest peak resident memory of the cluster's workers [MiB]."""
    def peak():
        import resource
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return max(client.run(peak).values())


def time_batch(paths, candidates, workers, out_dir):
    """Seconds for run_batch on a local cluster of `workers`; (seconds, results, MiB)."""
    client = batch.start_client(workers=workers)
    try:
        client.run(lambda: None)               # workers up before the clock starts
        options = batch.BatchOptions(candidates=candidates, reports=False)
        start = time.perf_counter()
        results = batch.run_batch(paths, out_dir, options, client, force=True)
        seconds = time.perf_counter() - start
        return seconds, results, worker_peak_rss(client)
    finally:
        cluster = client.cluster
        client.close()
        cluster.close()


def main(argv=None):
    """Run the benchmark and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--records', type=int, default=8)
    ap.add_argument('--minutes', type=float, default=4.0, help='record length [min]')
    ap.add_argument('--rate', type=float, default=20.0, help='sample rate [Hz]')
    ap.add_argument('--candidates', nargs='*', default=None,
                    help='candidate effects (default: the whole catalog)')
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        paths = make_records(tmp, args.records, args.minutes, args.rate)
        fit_model(load_data(paths[0]))                      # warm-up: numba caches
        print(f'{args.records} records of {args.minutes:g} min at {args.rate:g} Hz, '
              f'candidates: {" ".join(args.candidates) if args.candidates else "all"}')
        loop_s, named = time_loop(paths, args.candidates)
        rows = [('loop (1 process)', loop_s, None)]
        for workers in (1, 2):
            seconds, results, rss = time_batch(paths, args.candidates, workers,
                                               Path(tmp) / f'out{workers}')
            rows.append((f'batch, {workers} worker(s)', seconds, rss))
            cpu = np.mean([r['task_time_s'] for r in results if not r['error']])
    print(f'{"run":<20} {"wall [s]":>9} {"records/min":>12} {"vs loop":>8} '
          f'{"worker peak RSS [MiB]":>22}')
    for name, seconds, rss in rows:
        print(f'{name:<20} {seconds:9.1f} {60 * args.records / seconds:12.2f} '
              f'{seconds / loop_s:8.2f} {"" if rss is None else f"{rss:22.0f}"}')
    print(f'CPU per record in the batch (base fit + refits): {cpu:.1f} s; named in the loop: '
          f'{sum(n == "delay" for n in named)} delay of {args.records // 2} with delay')


if __name__ == '__main__':
    main()
