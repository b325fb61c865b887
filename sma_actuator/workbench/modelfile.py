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
MODEL.yaml: which effects a model includes and, once fitted, their values.

Shape (written from the engine's ``ModelFit.to_dict()``, read back by ``load_fit``)::

    effects: [saturation, delay]      # catalog effect names (required)
    kind: modified                    # hysteresis base: classical | modified (optional)
    parameters: {tau_s: 2.1, ...}     # fitted effect values (FITTED.yaml only)
    model: {...}                      # all fitted model values: actuator parameters with
                                      # the play-operator hysteresis (dynamic), or just
                                      # {hysteresis: ...} (static curves) (FITTED.yaml only)
    scores: {train: {...}, validation: {...}}

A hand-written MODEL.yaml needs only ``effects`` (and ``kind`` for a classical base);
`compare` needs a fitted file (written by ``sma-model fit --out``).
"""
import os
from pathlib import Path
import tempfile

import numpy as np
import yaml

KINDS = ('classical', 'modified')


class ModelFileError(ValueError):
    """MODEL.yaml cannot be read or written as asked; the message names the file."""


def read_model(path, known_effects=None):
    """
    Read and check MODEL.yaml; returns the dict (effects list, optional kind, ...).

    known_effects: names accepted in ``effects`` (default: no name check).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except FileNotFoundError:
        raise ModelFileError(f'{path}: no such model file') from None
    except (OSError, UnicodeDecodeError) as err:
        raise ModelFileError(f'{path}: cannot read: {getattr(err, "strerror", None) or err}') \
            from None
    try:
        spec = yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, 'problem_mark', None)
        where = f' at line {mark.line + 1}' if mark is not None else ''
        problem = getattr(err, 'problem', None) or str(err).splitlines()[0]
        raise ModelFileError(f'{path}: not valid YAML{where}: {problem}') from None
    return check_model(spec, path, known_effects)


def check_model(spec, source, known_effects=None):
    """Check the shape of a model dict; raises `ModelFileError` naming `source`."""
    if not isinstance(spec, dict):
        raise ModelFileError(f'{source}: expected a mapping with an "effects" list, got '
                             f'{type(spec).__name__}')
    effects = spec.get('effects', [])
    if effects is None:
        effects = []
    if not isinstance(effects, list) or not all(isinstance(e, str) for e in effects):
        raise ModelFileError(f'{source}: "effects" must be a list of effect names')
    if known_effects is not None:
        unknown = [e for e in effects if e not in known_effects]
        if unknown:
            raise ModelFileError(f'{source}: unknown effect(s) {", ".join(unknown)} (a plug-in '
                                 'effect needs --plugin); known: '
                                 f'{", ".join(sorted(known_effects))}')
    kind = spec.get('kind')
    if kind is not None and kind not in KINDS:
        raise ModelFileError(f'{source}: "kind" must be one of {", ".join(KINDS)}, got {kind!r}')
    for key in ('parameters', 'model', 'scores'):
        if key in spec and spec[key] is not None and not isinstance(spec[key], dict):
            raise ModelFileError(f'{source}: "{key}" must be a mapping')
    return dict(spec, effects=list(effects))


def is_fitted(spec):
    """Return True if the model dict carries fitted values (a non-empty 'model' section)."""
    return bool(spec.get('model'))


def is_static_model(spec):
    """Return True if the fitted model is a static hysteresis operator (fitted on curve data)."""
    return set(spec.get('model') or {}) == {'hysteresis'}


def check_writable(path, force=False):
    """Raise `ModelFileError` if writing `path` would overwrite a file without force."""
    path = Path(path)
    if path.is_dir():
        raise ModelFileError(f'{path}: is a directory, not a model file')
    if path.exists() and not force:
        raise ModelFileError(f'{path}: exists; use --force to overwrite it')
    if not path.parent.is_dir():
        raise ModelFileError(f'{path}: directory {path.parent} does not exist')


def to_plain(obj):
    """Numpy scalars/arrays and tuples -> plain Python (YAML- and JSON-safe)."""
    if isinstance(obj, dict):
        return {str(k): to_plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_plain(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def write_model(path, spec, force=False):
    """Write the model dict to `path` as YAML (atomically: temporary file, then rename)."""
    check_writable(path, force)
    path = Path(path)
    text = yaml.safe_dump(to_plain(spec), sort_keys=False, default_flow_style=None, width=100)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f'.{path.name}.', suffix='.tmp')
    try:
        with os.fdopen(fd, 'w', encoding='utf-8') as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
    return path
