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
`--dist loadfile` scheduling that survives a crashed pytest-xdist worker (a pytest plugin).

pytest-xdist 3.8.0 puts every file a crashed worker held back in its queue, finished files
and the test the worker died on included. A replacement worker handed a finished file waits
for tests forever, so the whole session hangs (pytest-dev/pytest-xdist#1323, fixed after
3.8.0); one handed the crashing test runs it again. And a worker runs a test only once it holds
the next one or is told to stop, which the initial schedule ensures and a replacement's does
not: one handed a one-test file waits too. Here only the unfinished files go back, the test the
worker died on counts as done (it is reported failed once, and the rest of its file runs on the
replacement, as under `--dist load`), and a node gets work until it holds two tests or the
queue is empty, when it is told to stop.
"""
import pytest
from xdist.scheduler import LoadFileScheduling


class CrashSafeLoadFileScheduling(LoadFileScheduling):
    """LoadFileScheduling that re-queues only unfinished work and never leaves a node waiting."""

    def remove_node(self, node):
        """Forget `node`; return the test it crashed on (None when it finished its work)."""
        workload = self.assigned_work.pop(node)
        pending = [(scope, nodeid) for scope, tests in workload.items()
                   for nodeid, done in tests.items() if not done]
        if not pending:
            return None
        scope, crashed = pending[0]       # a worker runs its tests in order: the first undone
        workload[scope][crashed] = True
        self.workqueue.update((scope, tests) for scope, tests in workload.items()
                              if not all(tests.values()))
        for other in self.assigned_work:
            self._reschedule(other)
        return crashed

    def _reschedule(self, node):
        """Give `node` work units until it holds two tests; tell it to stop once none are left."""
        super()._reschedule(node)
        while (self.workqueue and not node.shutting_down
               and self._pending_of(self.assigned_work[node]) < 2):
            self._assign_work_unit(node)
        if not self.workqueue and not node.shutting_down:
            node.shutdown()


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """Return the crash-safe scheduler for `--dist loadfile`; None leaves the others alone."""
    if config.getvalue('dist') != 'loadfile':
        return None
    return CrashSafeLoadFileScheduling(config, log)
