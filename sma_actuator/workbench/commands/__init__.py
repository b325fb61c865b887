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
The commands of `sma-model` (`workbench.cli`): one module each, the steps they share in `steps`.

Each module's `cmd_NAME(args)` runs one command on the parsed command line and returns its
exit code; bad input raises `steps.UsageError` (or another ValueError) for `cli.main` to
report as one line.
"""
