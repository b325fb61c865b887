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
Shared pytest fixtures.

ROS tests run in their own DDS domain (random ROS_DOMAIN_ID, localhost-only discovery)
so that concurrently running test sessions on one machine never see each other's topics;
the workers of one session (pytest-xdist) draw from disjoint sets of ids.
"""
import os
from pathlib import Path
import random
import time

# One BLAS thread, set before anything imports numpy: on a loaded machine OpenBLAS's
# spinning threads fight the other jobs for the cores and slow the fits many times over
# (the workbench's worker processes use one thread each already).
for _name in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS'):
    os.environ.setdefault(_name, '1')

import pytest  # noqa: E402

from sma_actuator.workbench.parallel import keep_freed_memory  # noqa: E402
# a hook: `--dist loadfile` that finishes the session after a crashed or hung worker
from support.xdist_scheduling import pytest_xdist_make_scheduler  # noqa: E402, F401, I100

keep_freed_memory()   # as `sma-model` runs: fits reuse their freed arrays

ROOT = Path(__file__).resolve().parents[1]


def real_data_path():
    """Return the measured morphing-wing loops: $SMA_SHARED_DIR, else shared/ beside the clone."""
    base = os.environ.get('SMA_SHARED_DIR')
    candidates = ([Path(base)] if base else []) + [ROOT.parent / 'shared']
    for c in candidates:
        path = c / 'data' / 'real' / 'morphing_wing_sma_loops.csv'
        if path.is_file():
            return str(path)
    return str(candidates[-1] / 'data' / 'real' / 'morphing_wing_sma_loops.csv')


os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


# How long a test waits to notice an event: only a bound that stops a broken build from
# hanging, never a timing requirement (the suite must pass on a loaded machine). Waits return
# as soon as the event is seen, so a generous bound costs nothing on a passing run.
NOTICE_S = 30.0


def spin_until(executor, condition, timeout_s=NOTICE_S, step_s=0.01):
    """Spin `executor` until `condition()` holds or `timeout_s` passes; return whether it held."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=step_s)
        if condition():
            return True
    return False


def pytest_collection_modifyitems(items):
    """Mark every test that uses the ROS fixtures `ros` (`-m "not ros"`: the ROS-free part)."""
    for item in items:
        if 'ros_domain_id' in getattr(item, 'fixturenames', ()):
            item.add_marker(pytest.mark.ros)


def domain_ids():
    """
    Return the DDS domain ids this test process draws from.

    1-100, split between pytest-xdist workers (worker k of N takes k + 1, k + 1 + N, ...),
    so that tests running side by side in one session never share a domain.
    """
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
    count = int(os.environ.get('PYTEST_XDIST_WORKER_COUNT', '1'))
    return range(1 + int(worker.lstrip('gw') or 0), 101, max(count, 1))


@pytest.fixture
def catalog_guard():
    """Remove effects a test registers, so plug-ins do not leak into other tests."""
    from sma_actuator.workbench.effects import CATALOG
    before = dict(CATALOG)
    yield
    CATALOG.clear()
    CATALOG.update(before)


@pytest.fixture
def ros_domain_id():
    """Return a DDS domain id private to this test (also exported for subprocess nodes)."""
    domain = random.SystemRandom().choice(domain_ids())
    old = os.environ.get('ROS_DOMAIN_ID')
    os.environ['ROS_DOMAIN_ID'] = str(domain)
    yield domain
    if old is None:
        os.environ.pop('ROS_DOMAIN_ID', None)
    else:
        os.environ['ROS_DOMAIN_ID'] = old


@pytest.fixture
def ros_context(ros_domain_id):
    """Return an initialised rclpy Context on the private domain; shut down after the test."""
    rclpy = pytest.importorskip('rclpy')
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=ros_domain_id)
    yield context
    if context.ok():
        rclpy.shutdown(context=context)
