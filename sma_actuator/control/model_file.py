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
