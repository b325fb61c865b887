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
How the tests judge a node process's exit after its stop signal.

A node whose middleware teardown (rclpy's `destroy_node`) still runs 10 s after its stop
signal is ended by its stop grace with status 1 and its stacks on stderr (docs/nodes.md
"Stopping"). That hang is the middleware's (eProsima/Fast-DDS#235) and comes after the
node's last word (zero duty sent, bag closed), so it counts as a clean stop; any other
status 1 does not.
"""
import re

# the stop grace's dump (faulthandler) with rclpy's destroy_node as the innermost frame
TEARDOWN_HUNG = re.compile(r'Timeout \(\d+:\d\d:\d\d(?:\.\d+)?\)!\n(?:Current thread|Thread) '
                           r'[^\n]*\n'
                           r' +File "[^"\n]*rclpy/node\.py", line \d+ in destroy_node\n')


def teardown_hung(returncode, stderr):
    """Return True if a node exited 1 from its stop grace while rclpy destroyed its node."""
    return returncode == 1 and TEARDOWN_HUNG.search(stderr) is not None


def stopped_cleanly(returncode, stderr):
    """Return True for exit status 0, or for a hang in the middleware's teardown."""
    return returncode == 0 or teardown_hung(returncode, stderr)
