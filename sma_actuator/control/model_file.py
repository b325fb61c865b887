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

"""Controller model files: an `ActuatorParams` in its `to_dict()` form as YAML (config/)."""
import json
from pathlib import Path

import yaml

from ..core.actuator import ActuatorParams


def load_model(path):
    """Read an ActuatorParams YAML (unknown keys raise, see `ActuatorParams.from_dict`)."""
    with open(path) as f:
        return ActuatorParams.from_dict(yaml.safe_load(f))


def save_model(params, path, header=''):
    """Write `params` as YAML with an optional comment header (provenance of the model)."""
    # numpy scalars from a fit -> plain floats, so the file is safe_load-able anywhere
    data = json.loads(json.dumps(params.to_dict(), default=float))
    text = ''.join(f'# {line}\n' for line in header.splitlines())
    Path(path).write_text(text + yaml.safe_dump(data, sort_keys=False))
