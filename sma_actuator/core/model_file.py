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
The package's one model file: what ``sma-model fit --out`` writes and everything reads.

The workbench reads and writes it (`sma-model fit --out`, `compare --model`); the
controller, plant_sim and the ROS-free API read the actuator model out of it with
`load_model`. The format is described once, in docs/workbench.md ("The model file")::

    effects: [saturation, delay]      # catalog effect names (required)
    kind: modified                    # hysteresis base: classical | modified (optional)
    parameters: {tau_s: 2.1, ...}     # fitted effect values (FITTED.yaml only)
    model: {...}                      # all fitted model values: actuator parameters with
                                      # the play-operator hysteresis (dynamic), or just
                                      # {hysteresis: ...} (static curves) (FITTED.yaml only)
    scores: {train: {...}, validation: {...}}

A hand-written MODEL.yaml needs only ``effects`` (and ``kind`` for a classical base).
Other top-level keys (provenance, layouts, units added by newer writers) are kept out of
the way. Files of the old controller format (the `ActuatorParams` fields at the top level,
as config/ held before) are converted by `load_model`, with a `ModelFormatWarning` that
says how to rewrite them.
"""
from __future__ import annotations

from dataclasses import fields
import os
from pathlib import Path
import tempfile
from typing import Any, Collection, Iterable, Mapping, Optional, Union
import warnings

import numpy as np
import yaml

from .actuator import ActuatorParams

__all__ = ['KINDS', 'ModelFileError', 'ModelFormatWarning', 'check_model', 'check_writable',
           'creation_problem', 'is_fitted', 'is_static_model', 'load_model', 'read_model',
           'save_model', 'to_plain', 'write_model']

KINDS = ('classical', 'modified')
_FIELDS = frozenset(f.name for f in fields(ActuatorParams))

PathLike = Union[str, os.PathLike]


class ModelFileError(ValueError):
    """A model file cannot be read or written as asked; the message names the file."""


class ModelFormatWarning(UserWarning):
    """A model file was read in an older or newer shape than this package writes."""


def read_model(path: PathLike, known_effects: Optional[Collection[str]] = None) -> dict:
    """
    Read and check a model file; return the dict (effects list, optional kind, ...).

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


def check_model(spec: Any, source: Union[str, os.PathLike],
                known_effects: Optional[Collection[str]] = None) -> dict:
    """Check the shape of a model dict; raise `ModelFileError` naming `source`."""
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


def is_fitted(spec: Mapping[str, Any]) -> bool:
    """Return True if the model dict carries fitted values (a non-empty 'model' section)."""
    return bool(spec.get('model'))


def is_static_model(spec: Mapping[str, Any]) -> bool:
    """Return True if the fitted model is a static hysteresis operator (fitted on curve data)."""
    return set(spec.get('model') or {}) == {'hysteresis'}


def check_writable(path: PathLike, force: bool = False, directory: bool = False) -> None:
    """
    Raise `ModelFileError` if writing `path` would overwrite a file without force.

    Also if its directory is missing or no file can be made there (`creation_problem`):
    a command checks this before its fit, so that the fit is not lost at the end.

    directory: `path` may be a directory (a bag's); else an existing directory is refused.
    """
    path = Path(path)
    if path.is_dir() and not directory:
        raise ModelFileError(f'{path}: is a directory, not a model file')
    if path.exists() and not force:
        raise ModelFileError(f'{path}: exists; use --force to overwrite it')
    if not path.parent.is_dir():
        raise ModelFileError(f'{path}: directory {path.parent} does not exist')
    where = path if path.is_dir() else path.parent
    problem = creation_problem(where)
    if problem:
        raise ModelFileError(f'{path}: cannot write in {where} ({problem})')


def creation_problem(directory: PathLike) -> Optional[str]:
    """
    Return why no file can be made in `directory` (e.g. 'Permission denied'), or None.

    Found by making and removing a temporary file there: a permission, a read-only or a
    pseudo file system shows only when a file is made, and the output comes after a fit
    of minutes.
    """
    try:
        with tempfile.TemporaryFile(dir=directory):
            return None
    except OSError as err:
        return err.strerror or str(err)


def to_plain(obj: Any) -> Any:
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


def json_safe(obj: Any) -> Any:
    """Return plain JSON data (`to_plain`), non-finite floats as None (strict JSON has no NaN)."""
    obj = to_plain(obj)
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [json_safe(v) for v in obj]
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def write_model(path: PathLike, spec: Mapping[str, Any], force: bool = False) -> Path:
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


def load_model(path: PathLike) -> ActuatorParams:
    """
    Return the actuator model (`ActuatorParams`) of a model file.

    path: a file written by ``sma-model fit --out`` (or `save_model`); an old-style file
    (the `ActuatorParams` fields at the top level) is converted with a
    `ModelFormatWarning`. Raises `ModelFileError` (a ValueError) with a one-line message
    naming the file when it cannot be used for control: missing, not YAML, a static
    (curve-only) fit, a fit of another rig (one wire against a bias spring, positions in
    another unit than rad, or a negative stroke: wire a turning the shaft towards −φ), or
    invalid parameter values.
    """
    spec = read_model(path)
    _check_control_rig(path, spec)
    model = spec.get('model')
    if not model:
        top = set(spec) - {'effects'}
        if top and top <= _FIELDS:
            warnings.warn(f'{path}: old controller model format (ActuatorParams at the top '
                          'level), converted; rewrite it with sma_actuator.core.model_file.'
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
        params = ActuatorParams.from_dict({k: v for k, v in model.items() if k in _FIELDS})
    except (TypeError, ValueError, KeyError) as err:
        raise ModelFileError(f'{path}: invalid model: {err}') from None
    if params.stroke_rad < 0:
        raise ModelFileError(f'{path}: heating wire a lowers the reading in this fit '
                             f'(stroke_rad {params.stroke_rad:.4g} < 0); the controller turns '
                             'the shaft towards +φ with wire a: swap duty_a and duty_b (or the '
                             "position's sign) in the records and fit again")
    return params


def _check_control_rig(path: PathLike, spec: Mapping[str, Any]) -> None:
    """Raise `ModelFileError` unless the fit's rig is the antagonistic pair read in rad."""
    if spec.get('layout', 'antagonistic') != 'antagonistic':
        raise ModelFileError(f'{path}: fitted on one wire against a bias spring; the '
                             'controller and the simulated plant drive an antagonistic pair')
    unit = spec.get('position_unit', 'rad')
    if unit != 'rad':
        raise ModelFileError(f'{path}: fitted on positions in {unit}; the controller and the '
                             'simulated plant work in rad (fit records of the shaft angle)')


def save_model(params: ActuatorParams, path: PathLike, header: str = '',
               effects: Iterable[str] = (), scores: Optional[Mapping[str, Any]] = None,
               force: bool = True) -> Path:
    """
    Write `params` in the model file format, with a comment header.

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
