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
Run independent CPU-bound jobs on every core.

Diagnose's candidate refits, and the hidden-effect tests and benchmark (one record per core).
"""
from __future__ import annotations

import atexit
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
import ctypes
import multiprocessing
import os
from typing import Callable, Iterable, Iterator, Optional, Tuple, TypeVar

T = TypeVar('T')
R = TypeVar('R')
BLAS_THREADS = ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS')
# glibc malloc: blocks up to this size come from the heap (glibc's own upper limit) ...
MMAP_THRESHOLD_B = 32 << 20
# ... and the heap's free top is given back to the kernel only beyond this size
TRIM_THRESHOLD_B = 1 << 30
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3   # mallopt parameters (malloc.h)
# this process's worker pool and its size, kept from one `imap_on_cores` to the next
_pool: Optional[ProcessPoolExecutor] = None
_pool_size = 0


def one_blas_thread() -> None:
    """
    Ask for one BLAS thread in this process, as the workers run; call before numpy loads.

    With several threads the least-squares rounding differs, the identification's searches
    can end in another basin, and a fit in the calling process would disagree with the same
    fit in a worker (`--jobs`). A thread count already set in the environment is kept.
    """
    for name in BLAS_THREADS:
        os.environ.setdefault(name, '1')


def keep_freed_memory() -> None:
    """
    Keep freed arrays of up to 32 MiB in this process for reuse (glibc; elsewhere no-op).

    A fit allocates and frees regressor matrices of a few MiB thousands of times. By
    default glibc maps many of them with mmap and unmaps or trims them when freed, so the
    next ones are faulted in page by page again: kernel time that is about a tenth of a
    diagnosis's CPU time on a virtual machine (docs/workbench.md, "Speed"). Served from a
    heap that is not trimmed, they cost at most the largest working set.
    Sets this process (mallopt) and, through the environment, the processes it starts.
    """
    os.environ.setdefault('MALLOC_MMAP_THRESHOLD_', str(MMAP_THRESHOLD_B))
    os.environ.setdefault('MALLOC_TRIM_THRESHOLD_', str(TRIM_THRESHOLD_B))
    mallopt = getattr(ctypes.CDLL(None), 'mallopt', None)
    if mallopt is not None:
        mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_B)
        mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_B)


def available_cores() -> int:
    """Return the number of cores this process may run on."""
    return len(os.sched_getaffinity(0))


def imap_on_cores(fn: Callable[[T], R], items: Iterable[T],
                  workers: Optional[int] = None) -> Iterator[Tuple[T, R]]:
    """
    Yield (item, fn(item)) as each finishes, on `workers` processes.

    `workers` defaults to the cores this process may use. One BLAS thread per worker (the
    workers already fill the cores); spawn, not fork: the caller may hold DDS or numba
    threads that must not be forked. The worker processes are kept for the next call
    (`shared_pool`): starting one costs about 2 s of CPU (the imports and the compiled
    kernels), as much as a small fit. A call that ends early (an error in fn, Ctrl-C, the
    caller stopping) shuts them down.

    fn must be importable (a module-level function).
    """
    items = list(items)
    workers = max(1, min(len(items), workers or available_cores()))
    if workers == 1:
        for item in items:
            yield item, fn(item)
        return
    saved = {k: os.environ.get(k) for k in BLAS_THREADS}
    os.environ.update(dict.fromkeys(BLAS_THREADS, '1'))   # workers start as tasks arrive
    finished = False
    try:
        pool, queue, futures = shared_pool(workers), iter(items), {}
        while True:
            while len(futures) < workers:   # at most `workers` run in a larger kept pool
                item = next(queue, queue)
                if item is queue:
                    break
                futures[pool.submit(fn, item)] = item
            if not futures:
                break
            done, _ = wait(futures, return_when=FIRST_COMPLETED)
            for f in done:
                yield futures.pop(f), f.result()
        finished = True
    finally:
        if not finished:
            shutdown_pool()
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def shared_pool(workers: int) -> ProcessPoolExecutor:
    """Return this process's kept worker pool, started anew if it has fewer than `workers`."""
    global _pool, _pool_size
    if _pool is None or _pool_size < workers:
        shutdown_pool()
        spawn = multiprocessing.get_context('spawn')
        _pool, _pool_size = ProcessPoolExecutor(max_workers=workers, mp_context=spawn), workers
    return _pool


@atexit.register
def shutdown_pool() -> None:
    """Stop the kept worker pool: queued jobs are cancelled, running ones finish."""
    global _pool, _pool_size
    pool, _pool, _pool_size = _pool, None, 0
    if pool is not None:
        pool.shutdown(wait=True, cancel_futures=True)
