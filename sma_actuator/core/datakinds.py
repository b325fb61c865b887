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
The two kinds of data a model is identified on, behind one interface.

* `DynamicData`: a uniformly sampled run, time [s], duties [0, 1], position, optional
  ambient [°C] and setpoint; possibly several records joined at rest.
* `StaticData`: quasi-static input -> output curves, each simulated from the reset state.

Callers ask the data instead of testing its kind:

* ``kind`` ('dynamic' | 'static'): the name used in files and JSON;
* ``output``: the measured output; ``scored_mask()``: the measured samples; ``span()``: the
  range of the measured output, the NRMSE scale;
* ``default_split(train_fraction)``, ``held_out(split)`` and ``split_masks(split)``: the
  train/validation division (a `Split`, one type for both kinds);
* ``simulate(model)``: the prediction of a fitted model over every sample (one flat array);
* ``unsupported(effect)``: why an effect cannot be fitted on this data, or None;
* ``regime_axis`` / ``figures``: the x axis of plots and the figures a report draws;
* ``noun``, ``joinable``, ``rig()``, ``scored_split(split)`` and ``columns()``: what the
  command line says about the data and checks against a model file.
"""
from dataclasses import dataclass
from typing import Any, ClassVar, Optional

import numpy as np

from .validate import finite_array, same_length

# share of a single record's time that trains when no records are held out
TRAIN_FRACTION = 0.7
# sum of the two duties' ranges below which a record cannot identify the thermal and
# hysteresis parameters (the wires hardly move through their loops)
MIN_DUTY_EXCITATION = 0.05
# largest spread of the sample steps, relative to their median, of uniformly sampled data
SAMPLING_TOLERANCE = 0.01


def uniform_steps(steps: np.ndarray) -> bool:
    """Return True if the time steps [s] spread by at most SAMPLING_TOLERANCE x their median."""
    return bool(np.ptp(steps) <= SAMPLING_TOLERANCE * np.median(steps))


@dataclass(frozen=True)
class Split:
    """
    Where training ends: the first held-out sample, or the held-out curves.

    start: first validation sample of a time split (dynamic data; None for curves).
    burn_in: first training sample (the simulation's start-up transient is not scored).
    curves: held-out curve ids (static data).
    """

    start: Optional[int] = None
    burn_in: int = 0
    curves: tuple = ()


class _Data:
    """The interface both data kinds implement (see the module docstring)."""

    kind: ClassVar[str] = ''
    #: a refit on this data is worth a worker process (a simulation-based fit)
    costly_fit: ClassVar[bool] = False
    #: (file name, caption) of the report's figures, in page order
    figures: ClassVar[tuple] = ()
    #: label of the sample axis of residual plots
    axis_label: ClassVar[str] = ''
    #: what the data is, in a sentence ('a dynamic record', 'static curves')
    noun: ClassVar[str] = ''
    #: several files of this kind can be joined into one data set
    joinable: ClassVar[bool] = False

    @property
    def output_unit(self) -> str:
        """Return the unit of the measured output, for what a person reads ('' if not known)."""
        return ''

    def rig(self) -> dict:
        """Return the rig settings a model fitted on this data must share ({} for none)."""
        return {}

    def scored_split(self, split: Optional[Split]) -> Optional[Split]:
        """Return `split` counted over the scored samples only (data with gaps cut out)."""
        return split

    def columns(self) -> dict:
        """Return the table columns saying what the data is: samples, duration, rate, rig."""
        raise NotImplementedError

    # `output` (the measured output) is a field or a property of each kind

    def scored_mask(self) -> np.ndarray:
        """Return the samples that are measured (not the rest gaps between records)."""
        return np.ones(len(self), bool)

    def span(self) -> float:
        """Return the range of the measured output over the whole data (the NRMSE scale)."""
        return float(np.ptp(self.output[self.scored_mask()]))

    def held_out(self, split: Optional[Split] = None) -> np.ndarray:
        """Return the held-out samples of `split` (default: `default_split`), gaps included."""
        raise NotImplementedError

    def default_split(self, train_fraction: float = TRAIN_FRACTION) -> Split:
        """Return the conventional split of this data."""
        raise NotImplementedError

    def split_masks(self, split: Split) -> tuple:
        """Return (train, validation) masks of the scored samples; train starts at burn_in."""
        val = self.held_out(split)
        train = ~val
        train[:split.burn_in] = False
        keep = self.scored_mask()
        return train & keep, val & keep

    def simulate(self, model: Any) -> tuple:
        """
        Return (prediction over every sample, model signals) of a fitted model.

        model: a `workbench.engine.ModelFit`-like object (its `trajectory` for dynamic data,
        its `params` hysteresis for static curves).
        """
        raise NotImplementedError

    def unsupported(self, effect: Any) -> Optional[str]:
        """Return why `effect` (a catalog `Effect`) cannot be fitted on this data, or None."""
        raise NotImplementedError

    def excitation_problem(self, to_fit: bool = True) -> Optional[str]:
        """
        Return why the data cannot identify a model (a constant signal), or None.

        to_fit False: why it cannot test a fitted model (the signals it needs to vary).
        """
        raise NotImplementedError

    def describe(self) -> str:
        """Return one line saying what the data is."""
        raise NotImplementedError


def _constant(pairs: tuple) -> Optional[str]:
    """Return the problem of the first constant (name, values) pair, or None."""
    for name, values in pairs:
        if np.ptp(values) <= 0.0:
            return f'{name} is constant ({values[0]:g}); nothing to identify'
    return None


@dataclass
class DynamicData(_Data):
    """A uniformly sampled run: time [s], duties [0, 1], position [rad], optional ambient [°C]."""

    time: np.ndarray
    duty_a: np.ndarray
    duty_b: np.ndarray
    position: np.ndarray
    ambient: np.ndarray = None
    setpoint: np.ndarray = None
    # unit of position and setpoint as read from the data ('rad' for the package's bags)
    position_unit: str = 'rad'
    # 'antagonistic' (two wires) or 'single' (one wire against a bias spring, duty_b = 0)
    layout: str = 'antagonistic'
    # several records joined at rest: ((name, start, stop), ...) sample ranges of the
    # records; `scored` marks the measured samples (False on the rest gaps between
    # records); `split` is where the held-out records start (None: the time split)
    segments: tuple = ()
    scored: np.ndarray = None
    split: int = None

    kind: ClassVar[str] = 'dynamic'
    costly_fit: ClassVar[bool] = True
    figures: ClassVar[tuple] = (
        ('time.png', 'Measured vs model over time'),
        ('residual.png', 'Residual e = measured − model'),
        ('hysteresis.png', 'Hysteresis plane: measured and model'))
    axis_label: ClassVar[str] = 'time [s]'
    noun: ClassVar[str] = 'a dynamic record'
    joinable: ClassVar[bool] = True

    def __post_init__(self) -> None:
        """Check the arrays: finite, of one length, time rising uniformly, duties in [0, 1]."""
        self.time = finite_array('time', self.time, min_len=10)
        for name in ('duty_a', 'duty_b', 'position'):
            setattr(self, name, finite_array(name, getattr(self, name)))
        same_length(time=self.time, duty_a=self.duty_a, duty_b=self.duty_b, position=self.position)
        for name in ('ambient', 'setpoint'):
            if getattr(self, name) is not None:
                setattr(self, name, finite_array(name, getattr(self, name)))
                same_length(time=self.time, **{name: getattr(self, name)})
        steps = np.diff(self.time)
        if (steps <= 0).any():
            k = int(np.flatnonzero(steps <= 0)[0])
            raise ValueError(f'time must be strictly increasing (row {k + 1}: {self.time[k + 1]} '
                             f'after {self.time[k]})')
        if not uniform_steps(steps):
            raise ValueError('time must be uniformly sampled (steps vary by more than '
                             f'{100 * SAMPLING_TOLERANCE:g} %)')
        for name in ('duty_a', 'duty_b'):
            d = getattr(self, name)
            if (d < 0).any() or (d > 1).any():
                raise ValueError(f'{name} must lie in [0, 1]')

    @property
    def dt(self) -> float:
        """Sample time [s]."""
        return float(np.median(np.diff(self.time)))

    def __len__(self) -> int:
        """Return the number of samples."""
        return len(self.time)

    @property
    def output(self) -> np.ndarray:
        """Return the measured position [position_unit]."""
        return self.position

    @property
    def output_unit(self) -> str:
        """Return the position unit as read from the data ('' if not known)."""
        return self.position_unit or ''

    def scored_mask(self) -> np.ndarray:
        """Return the samples that are measured (not the rest gaps between records)."""
        return np.ones(len(self), bool) if self.scored is None else np.asarray(self.scored, bool)

    def default_split(self, train_fraction: float = TRAIN_FRACTION) -> Split:
        """
        Return the held-out records' start, else the time split.

        The time split leaves the first `train_fraction` of the measured samples (the
        lead-in of a joined record is not counted) for training.
        """
        if self.split:
            return Split(int(self.split))
        measured = np.flatnonzero(self.scored_mask())
        return Split(int(measured[min(int(round(train_fraction * len(measured))),
                                      len(measured) - 1)]))

    def held_out(self, split: Optional[Split] = None) -> np.ndarray:
        """Return the samples from the split's start on (default: the time split)."""
        start = (split or self.default_split()).start
        return np.arange(len(self)) >= start

    def simulate(self, model: Any) -> tuple:
        """Return (free-run position, model wire temperatures and outputs) of `model`."""
        t = model.trajectory(self)
        return t.position_rad, {'theta_a': t.theta_a_c, 'theta_b': t.theta_b_c, 'y_a': t.y_a,
                                'y_b': t.y_b, 'time': self.time}

    def unsupported(self, effect: Any) -> Optional[str]:
        """Return why `effect` cannot be fitted on this record (rig layout, data), or None."""
        if effect.needs_two_wires and self.layout == 'single':
            return 'needs two wires (this is a single wire against a bias spring)'
        return effect.applicable(self)

    def rig(self) -> dict:
        """Return the position unit and wire layout, which a model file fitted here records."""
        return {'position_unit': self.position_unit, 'layout': self.layout}

    def scored_split(self, split: Optional[Split]) -> Optional[Split]:
        """
        Return the time split `split` as an index into the scored samples (no burn-in).

        start' = number of scored samples before `split.start` (the rest gaps are cut out).
        """
        if split is None:
            return None
        start = split.start
        if self.scored is not None:
            start = int(np.count_nonzero(self.scored[:start]))
        return Split(start)

    def columns(self) -> dict:
        """Return samples, duration [s], rate [Hz], layout and position unit of the record."""
        return {'samples': len(self), 'duration_s': float(self.time[-1] - self.time[0]),
                'rate_hz': float(1.0 / self.dt), 'layout': self.layout,
                'position_unit': self.position_unit}

    def excitation_problem(self, to_fit: bool = True) -> Optional[str]:
        """
        Return why the record cannot identify the model: duties or position constant.

        A fitted model is tested on any record that moves: a constant duty from the first
        sample is a step from rest.
        """
        if to_fit and np.ptp(self.duty_a) + np.ptp(self.duty_b) < MIN_DUTY_EXCITATION:
            return (f'duty_a and duty_b hardly vary (ranges {np.ptp(self.duty_a):.3g}, '
                    f'{np.ptp(self.duty_b):.3g}), the thermal and hysteresis parameters '
                    'cannot be identified')
        return _constant((('position', self.position),))

    def describe(self) -> str:
        """Return e.g. 'dynamic record: 2400 samples at 40 Hz (60 s), antagonistic pair, ...'."""
        extras = [name for name, v in (('ambient', self.ambient), ('setpoint', self.setpoint))
                  if v is not None]
        span = self.time[-1] - self.time[0]
        rig = ('one wire against a bias spring' if self.layout == 'single'
               else 'antagonistic pair')
        return (f'dynamic record: {len(self)} samples at {1.0 / self.dt:.4g} Hz ({span:.4g} s), '
                f'{rig}, position in {self.position_unit}'
                + (f', with {" and ".join(extras)}' if extras else ''))


@dataclass
class StaticData(_Data):
    """Quasi-static curves: input, output, curve id per sample (curves start from reset)."""

    input: np.ndarray  # noqa: A003 (the pair input/output names the model's two signals)
    output: np.ndarray
    curve: np.ndarray

    kind: ClassVar[str] = 'static'
    figures: ClassVar[tuple] = (
        ('curves.png', 'Input-output plane per curve (measured dots, model lines; dashed: '
         'validation curves)'),
        ('residual.png', 'Residual e = measured − model'))
    axis_label: ClassVar[str] = 'sample (curves in file order)'
    noun: ClassVar[str] = 'static curves'

    def __len__(self) -> int:
        """Return the number of points."""
        return len(self.input)

    def curve_ids(self) -> list:
        """Return the curve ids in file order."""
        return list(dict.fromkeys(np.asarray(self.curve).tolist()))

    def default_split(self, train_fraction: float = TRAIN_FRACTION) -> Split:
        """Return the workbench convention: even curves train, odd ones validate."""
        return Split(curves=tuple(c for c in self.curve_ids() if c % 2 == 1))

    def held_out(self, split: Optional[Split] = None) -> np.ndarray:
        """Return the points of the held-out curves (default: the odd ids)."""
        return np.isin(self.curve, list((split or self.default_split()).curves))

    def flat(self, prediction: list) -> np.ndarray:
        """Return a per-curve prediction [(curve_id, array), ...] laid out like `output`."""
        out = np.full(len(self.output), np.nan)
        for cid, values in prediction:
            mask = np.asarray(self.curve) == cid
            values = np.asarray(values, float)
            if values.size != mask.sum():
                raise ValueError(f'prediction for curve {cid} has {values.size} points, the '
                                 f'data {mask.sum()}')
            out[mask] = values
        if np.isnan(out).any():
            raise ValueError('prediction misses some curves of the data')
        return out

    def simulate(self, model: Any) -> tuple:
        """
        Return (prediction, no signals) of `model`'s hysteresis on every curve.

        Each curve starts from the reset state at the lowest input of the data.
        """
        h = getattr(model.params, 'hysteresis', model.params)
        u0 = float(np.min(self.input))
        return self.flat([(c, h.simulate(self.input[self.curve == c], h.initial_state(u0)))
                          for c in self.curve_ids()]), {}

    def unsupported(self, effect: Any) -> Optional[str]:
        """Return why `effect` cannot be fitted on curves (it needs a time axis), or None."""
        reason = effect.applicable(self)
        if reason is None and effect.needs_dynamic:
            reason = 'needs dynamic (time-series) data'
        return reason

    def columns(self) -> dict:
        """Return the number of points; curves have no duration, rate or known unit."""
        return {'samples': len(self), 'duration_s': None, 'rate_hz': None,
                'layout': 'static curves', 'position_unit': None}

    def excitation_problem(self, to_fit: bool = True) -> Optional[str]:
        """Return why the curves cannot identify or test the model: output or input constant."""
        return _constant((('output', self.output), ('input', self.input)))

    def describe(self) -> str:
        """Return e.g. 'static curves: 400 points on 8 curve(s) (train: even ids, ...)'."""
        curves = np.unique(self.curve)
        return (f'static curves: {len(self.input)} points on {curves.size} curve(s) '
                f'(train: even ids, validate: odd ids)')
