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
Node parameters: one table of :class:`Param` per node serves declaration, validation and help.

Each node module holds a ``PARAMETERS`` tuple. :func:`declare_parameters` declares every entry
with its ParameterDescriptor (type, range, allowed strings, read-only), checks the value a
user gave and keeps checking values set at runtime; :mod:`.ros_console` prints the same table
as ``--help`` and warns about parameters a node does not declare.
"""
from dataclasses import dataclass
import functools
import math
import textwrap
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)
from rclpy.node import Node
from rclpy.parameter import Parameter

KINDS = {'double': ParameterType.PARAMETER_DOUBLE, 'integer': ParameterType.PARAMETER_INTEGER,
         'bool': ParameterType.PARAMETER_BOOL, 'string': ParameterType.PARAMETER_STRING,
         'double_array': ParameterType.PARAMETER_DOUBLE_ARRAY,
         'string_array': ParameterType.PARAMETER_STRING_ARRAY}
# parameters rclpy declares on every node itself
RCLPY_PARAMETERS = ('use_sim_time', 'start_type_description_service')
# where declare_parameters keeps a node's table (read by ros_console.warn_parameter_sources)
TABLE_ATTRIBUTE = '_sma_parameters'


class ParameterError(ValueError):
    """A parameter value the node cannot run with (the message is one line)."""


@dataclass(frozen=True)
class Param:
    """
    Declare one node parameter: its name, default, description and allowed values.

    The type follows the default (float: double, int: integer, bool, str: string, list of
    float: double array, list of str: string array); `kind` names it when the default is
    None (an array that stays unset until given). `bounds` is the inclusive [lo, hi] of a
    number, `choices` the allowed strings.
    """

    name: str
    default: Any
    description: str
    bounds: Optional[Tuple[float, float]] = None
    choices: Optional[Tuple[str, ...]] = None
    read_only: bool = False
    kind: Optional[str] = None

    def type_name(self) -> str:
        """Return the parameter type: a key of KINDS."""
        if self.kind:
            return self.kind
        d = self.default
        if isinstance(d, bool):
            return 'bool'
        if isinstance(d, int):
            return 'integer'
        if isinstance(d, float):
            return 'double'
        if isinstance(d, str):
            return 'string'
        if isinstance(d, (list, tuple)) and d and all(isinstance(v, str) for v in d):
            return 'string_array'
        if isinstance(d, (list, tuple)):
            return 'double_array'
        raise TypeError(f'parameter {self.name}: cannot tell the type of default {d!r}')

    def descriptor(self) -> ParameterDescriptor:
        """Return the rcl_interfaces ParameterDescriptor the node declares."""
        kind = self.type_name()
        d = ParameterDescriptor(description=self.description, type=KINDS[kind],
                                read_only=self.read_only)
        if self.bounds is not None and kind == 'double':
            d.floating_point_range = [FloatingPointRange(from_value=float(self.bounds[0]),
                                                         to_value=float(self.bounds[1]))]
        elif self.bounds is not None and kind == 'integer':
            d.integer_range = [IntegerRange(from_value=int(self.bounds[0]),
                                            to_value=int(self.bounds[1]))]
        if self.choices:
            d.additional_constraints = f'one of: {", ".join(self.choices)}'
        return d

    def coerce(self, value: Any) -> Any:
        """
        Return `value` as this parameter's type, or raise ParameterError naming the rule.

        An integer is accepted for a double (`-p rate_hz:=50`), an integral double for an
        integer, an empty list (which rcl leaves untyped) for an array.
        """
        kind = self.type_name()
        if value is None and kind.endswith('_array'):
            return None if self.default is None else []
        if kind == 'double' and _is_number(value):
            value = float(value)
        elif kind == 'integer' and isinstance(value, float) and value.is_integer():
            value = int(value)
        elif kind == 'double_array' and isinstance(value, (list, tuple)) and all(
                _is_number(v) for v in value):
            value = [float(v) for v in value]
        elif kind == 'string_array' and isinstance(value, (list, tuple)) and all(
                isinstance(v, str) for v in value):
            value = list(value)
        elif not _has_kind(value, kind):
            raise ParameterError(f'parameter {self.name}: {value!r} is not '
                                 f'{_KIND_TEXT[kind]}')
        self.check(value)
        return value

    def check(self, value: Any) -> None:
        """Raise ParameterError if `value` (already of the right type) is not allowed."""
        if isinstance(value, float) and not math.isfinite(value):
            raise ParameterError(f'parameter {self.name}: {value} is not a finite number')
        if isinstance(value, list) and self.type_name() == 'double_array' and not all(
                math.isfinite(v) for v in value):
            raise ParameterError(f'parameter {self.name}: {value} holds a non-finite number')
        if self.bounds is not None and not self.bounds[0] <= value <= self.bounds[1]:
            raise ParameterError(f'parameter {self.name}: {value:g} is outside the allowed '
                                 f'range [{self.bounds[0]:g}, {self.bounds[1]:g}]')
        if self.choices and value not in self.choices:
            raise ParameterError(f'parameter {self.name}: {value!r} is not one of '
                                 f'{", ".join(self.choices)}')

    def help_lines(self, width: int = 88) -> List[str]:
        """Return the `--help` lines of this parameter."""
        facts = [self.type_name(), f'default {_show(self.default)}']
        if self.bounds is not None:
            facts.append(f'range [{self.bounds[0]:g}, {self.bounds[1]:g}]')
        if self.choices:
            facts.append(f'one of {", ".join(self.choices)}')
        if self.read_only:
            facts.append('read-only')
        return [f'  {self.name} ({", ".join(facts)})'] + textwrap.wrap(
            self.description, width, initial_indent=' ' * 6, subsequent_indent=' ' * 6)


_KIND_TEXT = {'double': 'a number', 'integer': 'an integer', 'bool': 'true or false',
              'string': 'a string', 'double_array': 'a list of numbers',
              'string_array': 'a list of strings'}


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _has_kind(value: Any, kind: str) -> bool:
    if kind == 'bool':
        return isinstance(value, bool)
    if kind == 'integer':
        return isinstance(value, int) and not isinstance(value, bool)
    if kind == 'string':
        return isinstance(value, str)
    return False


def _show(v: Any) -> str:
    if v is None:
        return 'unset'
    if isinstance(v, float):
        text = f'{v:.6g}'
        return text if set(text) & set('.en') else text + '.0'
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, bool):
        return str(v).lower()
    return str(v)


def declare_parameters(node: Node, params: Iterable[Param],
                       defaults: Optional[Mapping[str, Any]] = None) -> Dict[str, Any]:
    """
    Declare every `Param` of `params` on `node` and return {name: value}.

    The value is the override (`-p`, a params file, the constructor's
    `parameter_overrides`) if there is one, else the default (`defaults` replaces a
    table default). rcl resolves the overrides for the node's name and namespace; they are
    read through the public API by declaring each name dynamically typed first, then
    converted (an integer for a double...), checked against the table and declared again
    with the full descriptor (`ignore_override=True`).

    Raise ParameterError (one line naming the parameter and what it allows) for a value the
    node cannot use. At runtime an integer given for a double is converted too.
    """
    table = node.__dict__.setdefault(TABLE_ATTRIBUTE, {})
    first = not table
    values = {}
    for p in params:
        default = p.default if defaults is None else defaults.get(p.name, p.default)
        probe = node.declare_parameter(p.name, default, ParameterDescriptor(dynamic_typing=True))
        given = probe.value
        node.undeclare_parameter(p.name)
        value = p.coerce(given)
        if value is None or value == [] and p.type_name().endswith('_array'):
            # rcl types an empty list as nothing: declare the type, then set the empty value
            node.declare_parameter(p.name, Parameter.Type(KINDS[p.type_name()]),
                                   p.descriptor(), ignore_override=True)
            if value == [] and not p.read_only:
                node.set_parameters([Parameter(p.name, Parameter.Type(KINDS[p.type_name()]),
                                               [])])
        else:
            node.declare_parameter(p.name, value, p.descriptor(), ignore_override=True)
        table[p.name] = p
        values[p.name] = value
    if first:
        node.add_pre_set_parameters_callback(functools.partial(_convert_at_runtime, table))
        node.add_on_set_parameters_callback(functools.partial(_check_at_runtime, table))
    return values


def declared_names(node: Node) -> List[str]:
    """Return the names declare_parameters declared on `node`, in declaration order."""
    return list(node.__dict__.get(TABLE_ATTRIBUTE, {}))


def overrides_from_kwargs(params: Iterable[Param], kwargs: Mapping[str, Any]) -> List[Parameter]:
    """
    Turn `name=value` keyword arguments of an embedded node into rclpy parameter overrides.

    Raise ValueError for a name that is neither in `params` nor one rclpy declares; the
    values are converted and checked when the node declares them.
    """
    names = {p.name for p in params}
    unknown = sorted(set(kwargs) - names - set(RCLPY_PARAMETERS))
    if unknown:
        raise ValueError(f'unknown parameters {unknown}; known: {sorted(names)}')
    out = []
    for name, value in kwargs.items():
        if isinstance(value, (list, tuple)) and not value:
            out.append(Parameter(name, Parameter.Type.STRING_ARRAY, []))   # untyped otherwise
        else:
            out.append(Parameter(name, value=list(value) if isinstance(value, tuple) else value))
    return out


def declare_float(node: Node, name: str, default: float, description: str,
                  lo: Optional[float] = None, hi: Optional[float] = None,
                  read_only: bool = False) -> float:
    """
    Declare one double parameter outside the node's table; return its value.

    Kept for code written against the per-call helpers: `--help` prints only the table, so
    a new parameter belongs in the node's PARAMETERS (test_nodes_cli checks both agree).
    """
    bounds = None if lo is None else (lo, hi)
    return declare_parameters(node, [Param(name, float(default), description, bounds,
                                           read_only=read_only)])[name]


def declare_int(node: Node, name: str, default: int, description: str, lo: int, hi: int,
                read_only: bool = False) -> int:
    """Declare one integer parameter outside the node's table (see declare_float)."""
    return declare_parameters(node, [Param(name, int(default), description, (lo, hi),
                                           read_only=read_only)])[name]


def declare_bool(node: Node, name: str, default: bool, description: str,
                 read_only: bool = False) -> bool:
    """Declare one bool parameter outside the node's table (see declare_float)."""
    return declare_parameters(node, [Param(name, bool(default), description,
                                           read_only=read_only)])[name]


def declare_str(node: Node, name: str, default: str, description: str,
                choices: Optional[Sequence[str]] = None, read_only: bool = False) -> str:
    """Declare one string parameter outside the node's table (see declare_float)."""
    return declare_parameters(node, [Param(name, str(default), description,
                                           choices=tuple(choices) if choices else None,
                                           read_only=read_only)])[name]


def initial_value(node: Node, params: Iterable[Param], name: str) -> Any:
    """
    Return the value parameter `name` of `params` will be declared with, before declaring it.

    For a parameter whose value sets the defaults of others (plant_sim's `model_file`).
    """
    p = next(q for q in params if q.name == name)
    probe = node.declare_parameter(name, p.default, ParameterDescriptor(dynamic_typing=True))
    node.undeclare_parameter(name)
    return p.coerce(probe.value)


def _convert_at_runtime(table: Dict[str, Param],
                        parameters: List[Parameter]) -> List[Parameter]:
    """Turn an integer set on a double parameter (`ros2 param set ... 2`) into 2.0."""
    out = []
    for q in parameters:
        p = table.get(q.name)
        kind = p.type_name() if p else None
        if kind == 'double' and q.type_ == Parameter.Type.INTEGER:
            q = Parameter(q.name, Parameter.Type.DOUBLE, float(q.value))
        elif kind == 'double_array' and q.type_ == Parameter.Type.INTEGER_ARRAY:
            q = Parameter(q.name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in q.value])
        out.append(q)
    return out


def _check_at_runtime(table: Dict[str, Param],
                      parameters: List[Parameter]) -> SetParametersResult:
    """Refuse a runtime value that the table does not allow (choices, finite numbers)."""
    for q in parameters:
        p = table.get(q.name)
        if p is None or q.type_ != Parameter.Type(KINDS[p.type_name()]):
            continue   # rclpy checks the type and the descriptor's range itself
        try:
            p.check(q.value)
        except ParameterError as err:
            return SetParametersResult(successful=False, reason=str(err))
    return SetParametersResult(successful=True)
