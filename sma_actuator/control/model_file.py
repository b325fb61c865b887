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
The package's one model file, read for the controller, the plant and the estimator.

A model file is what ``sma-model fit --out FITTED.yaml`` writes
(`sma_actuator.workbench.modelfile`)::

    effects: [delay]            # catalog effects the model carries
    kind: modified              # hysteresis base
    parameters: {delay_s: 0.3}  # fitted effect values
    model: {...}                # every actuator parameter (`ActuatorParams.to_dict()`)
    scores: {train: {...}, validation: {...}}

`load_model` returns the `model` section as an `ActuatorParams`; other top-level keys
(provenance, layouts, units added by newer writers) are kept out of the way. Files of the
old controller format (an `ActuatorParams` at the top level, as config/ held before) are
converted on reading, with a `ModelFormatWarning` that says how to rewrite them.
"""
from dataclasses import fields
from pathlib import Path
import warnings

from ..core.actuator import ActuatorParams
from ..workbench.modelfile import ModelFileError, read_model, to_plain, write_model

__all__ = ['ModelFileError', 'ModelFormatWarning', 'load_model', 'save_model']

_FIELDS = frozenset(f.name for f in fields(ActuatorParams))


class ModelFormatWarning(UserWarning):
    """A model file was read in an older or newer shape than this package writes."""


def load_model(path):
    """
    Return the actuator model (`ActuatorParams`) of a model file.

    path: a file written by ``sma-model fit --out`` (or `save_model`); an old-style file
    (the `ActuatorParams` fields at the top level) is converted with a
    `ModelFormatWarning`. Raises `ModelFileError` (a ValueError) with a one-line message
    naming the file when it cannot be used for control: missing, not YAML, a static
    (curve-only) fit, or invalid parameter values.
    """
    spec = read_model(path)
    model = spec.get('model')
    if not model:
        top = set(spec) - {'effects'}
        if top and top <= _FIELDS:
            warnings.warn(f'{path}: old controller model format (ActuatorParams at the top '
                          'level), converted; rewrite it with sma_actuator.control.model_file.'
                          'save_model or sma-model fit --out', ModelFormatWarning, stacklevel=2)
            model = {k: v for k, v in spec.items() if k in _FIELDS}
        else:
            raise ModelFileError(f'{path}: no fitted model (the "model" section written by '
                                 'sma-model fit --out)')
    if set(model) == {'hysteresis'}:
        raise ModelFileError(f'{path}: a static (curve) fit has no thermal model; fit a '
                             'time-series recording for control')
    unknown = sorted(set(model) - _FIELDS)
    if unknown:
        warnings.warn(f'{path}: model keys not known to this version ignored: {unknown}',
                      ModelFormatWarning, stacklevel=2)
    try:
        return ActuatorParams.from_dict({k: v for k, v in model.items() if k in _FIELDS})
    except (TypeError, ValueError, KeyError) as err:
        raise ModelFileError(f'{path}: invalid model: {err}') from None


def save_model(params, path, header='', effects=(), scores=None, force=True):
    """
    Write `params` (`ActuatorParams`) in the model file format, with a comment header.

    header: provenance lines written as ``# ...`` comments above the YAML; effects: the
    catalog effects the model carries; scores: optional fit scores.
    """
    spec = {'effects': list(effects), 'kind': 'modified', 'parameters': {},
            'model': to_plain(params.to_dict()), 'scores': to_plain(scores or {})}
    path = write_model(path, spec, force=force)
    if header:
        text = ''.join(f'# {line}\n' for line in header.splitlines())
        path.write_text(text + Path(path).read_text(encoding='utf-8'), encoding='utf-8')
    return path
