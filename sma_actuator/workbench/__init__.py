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
Model workbench: compare the actuator model with measurements, find the missing effect.

Modules (see docs/workbench.md for the user walkthrough):

* `data`      – load DATA: dynamic CSV, static curve CSV or MCAP bag, with clear errors
* `records`   – join several dynamic records of one rig into one record set
* `limits`    – input limits of DATA, strict number parsing, load progress
* `engine`    – fit a model with a set of effects and score it on its records
* `judging`   – refit the model with one candidate effect and test what it gains
* `diagnosis` – judge every candidate, rank them, name the missing effect; the rounds
* `effects`   – the effect catalog (`CATALOG`, `Effect`, `register_effect`)
* `compare`   – error breakdown by regime and residual correlation tests
* `report`    – HTML report with PNG figures
* `plugins`   – user effects from a file, a module or the `sma_actuator.effects` entry points
* `parallel`  – independent CPU-bound jobs on every core (diagnose's candidate refits)
* `batch`     – fit, compare and diagnose many records on a Dask cluster
* `fleet`     – the batch table (Parquet, CSV) and its HTML index
* `cli`       – the `sma-model` command

Submodules are imported on use, so `import sma_actuator.workbench` stays cheap.
"""
