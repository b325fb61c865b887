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
Helpers shared by the nodes.

Topic names, QoS, the parameter layer (one table per node: declaration, validation,
--help, warnings about unused parameters), diagnostics, config files and the signal-safe
spin loop every console script runs.
"""
from dataclasses import dataclass
import functools
import math
from pathlib import Path
import re
import signal
import sys
import textwrap
import threading
from typing import Any, Optional, Tuple

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)
import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args
import yaml

# Topic names, relative to the node's namespace, so `-r __ns:=/left` (or launch_ros
# `Node(namespace=...)`) moves a whole actuator. Every node defaults to NAMESPACE, so the
# default names stay /sma/setpoint, /sma/duty, ... /diagnostics and /clock stay absolute
# (one per ROS graph, by ROS convention).
NAMESPACE = 'sma'
SETPOINT = 'setpoint'
DUTY = 'duty'
JOINT_STATES = 'joint_states'
AMBIENT_TEMPERATURE = 'ambient_temperature'
DIAGNOSTICS = '/diagnostics'
CLOCK = '/clock'
JOINT_NAME = 'shaft'
WIRE_FRAMES = ('wire_a', 'wire_b')
# one sensor_msgs/Temperature topic per wire (plotting tools key series by topic)
WIRE_TEMPERATURES = tuple(f'{frame}/temperature' for frame in WIRE_FRAMES)

# feedback streams: newest sample wins, a lost one is not worth a retransmission
SENSOR_QOS = qos_profile_sensor_data
# commands: every setpoint and duty must arrive (a lost "zero duty" would leave heat on)
COMMAND_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
DIAGNOSTICS_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
CLOCK_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR


def node_options(kwargs):
    """
    Return rclpy Node keyword arguments with the namespace defaulting to NAMESPACE.

    A `__ns` remap on the command line (`--ros-args -r __ns:=/left`, which launch_ros
    `Node(namespace=...)` passes) still takes precedence over this default, as in rcl.
    """
    return {'namespace': NAMESPACE, **kwargs}


def expiring_command_qos(lifespan_s):
    """
    Return COMMAND_QOS with a lifespan: samples older than `lifespan_s` are never taken.

    For the duty subscriptions of the plant and the bridge (docs/safety.md): a sample
    queued while the process was frozen expires instead of replaying old heat.
    """
    return QoSProfile(depth=COMMAND_QOS.depth, reliability=COMMAND_QOS.reliability,
                      lifespan=Duration(seconds=lifespan_s))


def install_stop_signals():
    """
    SIGINT and SIGTERM set the returned Event and raise nothing.

    Why not rclpy's handler: it chains to Python's default SIGINT handler, and the
    KeyboardInterrupt it raises can land inside a pybind11 call of the executor
    (`take_message`), which turns it into "RuntimeError: Unable to convert call argument"
    and exit status 1 (ros/joint_state_publisher#117; seen here under load). A flag that the
    spin loop polls stops every node between callbacks, with its context still valid, so
    the shutdown path can still publish a zero duty.
    """
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    return stop


def init_with_stop_signals(args=None, prog=None):
    """
    Run `rclpy.init(args)` without rclpy's signal handlers; return `install_stop_signals()`.

    With `prog`, a command line rcl cannot parse (a malformed `-p`, an unreadable params
    file) ends in one line on stderr and exit status 2 instead of a traceback.
    """
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except Exception as err:   # noqa: B902 - rcl's error type is in a private module
        if prog is None:
            raise
        fail(prog, f'cannot start: {_rcl_message(err)}')
    return install_stop_signals()


def spin_until_stopped(node, stop, done=None, poll_s=0.05):
    """
    Spin `node` until `stop` is set, `done()` is true or its context is shut down.

    A signal is seen within poll_s (the wait returns at least that often). Returns the
    executor, so a caller can still drain queued messages after the stop.
    """
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        while not stop.is_set() and node.context.ok() and not (done and done()):
            executor.spin_once(timeout_sec=poll_s)
    except ExternalShutdownException:
        pass   # someone else shut the context down: a normal stop
    return executor


# Node parameters: one table per node module (a tuple of `Param`) serves the declaration
# with descriptors, the validation of every value a user gives and `--help`, so what the
# help prints is what the node declares.
KINDS = {'double': ParameterType.PARAMETER_DOUBLE, 'integer': ParameterType.PARAMETER_INTEGER,
         'bool': ParameterType.PARAMETER_BOOL, 'string': ParameterType.PARAMETER_STRING,
         'double_array': ParameterType.PARAMETER_DOUBLE_ARRAY,
         'string_array': ParameterType.PARAMETER_STRING_ARRAY}
# parameters rclpy declares on every node itself
RCLPY_PARAMETERS = ('use_sim_time', 'start_type_description_service')


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

    def type_name(self):
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

    def descriptor(self):
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

    def coerce(self, value):
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

    def check(self, value):
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

    def help_lines(self, width=88):
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


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _has_kind(value, kind):
    if kind == 'bool':
        return isinstance(value, bool)
    if kind == 'integer':
        return isinstance(value, int) and not isinstance(value, bool)
    if kind == 'string':
        return isinstance(value, str)
    return False


def _show(v):
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


def declare_parameters(node, params, defaults=None):
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
    table = node.__dict__.setdefault('_sma_parameters', {})
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


def overrides_from_kwargs(params, kwargs):
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


def declare_float(node, name, default, description, lo=None, hi=None, read_only=False):
    """
    Declare one double parameter outside the node's table; return its value.

    Kept for code written against the per-call helpers: `--help` prints only the table, so
    a new parameter belongs in the node's PARAMETERS (test_nodes_cli checks both agree).
    """
    bounds = None if lo is None else (lo, hi)
    return declare_parameters(node, [Param(name, float(default), description, bounds,
                                           read_only=read_only)])[name]


def declare_int(node, name, default, description, lo, hi, read_only=False):
    """Declare one integer parameter outside the node's table (see declare_float)."""
    return declare_parameters(node, [Param(name, int(default), description, (lo, hi),
                                           read_only=read_only)])[name]


def declare_bool(node, name, default, description, read_only=False):
    """Declare one bool parameter outside the node's table (see declare_float)."""
    return declare_parameters(node, [Param(name, bool(default), description,
                                           read_only=read_only)])[name]


def declare_str(node, name, default, description, choices=None, read_only=False):
    """Declare one string parameter outside the node's table (see declare_float)."""
    return declare_parameters(node, [Param(name, str(default), description,
                                           choices=tuple(choices) if choices else None,
                                           read_only=read_only)])[name]


def initial_value(node, params, name):
    """
    Return the value parameter `name` of `params` will be declared with, before declaring it.

    For a parameter whose value sets the defaults of others (plant_sim's `model_file`).
    """
    p = next(q for q in params if q.name == name)
    probe = node.declare_parameter(name, p.default, ParameterDescriptor(dynamic_typing=True))
    node.undeclare_parameter(name)
    return p.coerce(probe.value)


def _convert_at_runtime(table, parameters):
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


def _check_at_runtime(table, parameters):
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


def parameter_help(prog, doc, params):
    """Return the `--help` text: usage, the docstring's first paragraph and every parameter."""
    summary = (doc or '').strip().split('\n\n')[0]
    lines = [f'usage: {prog} [-h] [--ros-args [-p NAME:=VALUE ...] [--params-file FILE ...]]',
             '', summary, '',
             'Parameters (--ros-args -p NAME:=VALUE, or a --params-file YAML):']
    for p in params:
        lines.extend(p.help_lines())
    lines += ['', 'Also any ROS argument after --ros-args: -p use_sim_time:=true,',
              '-r __ns:=/left, --log-level debug, ...']
    return '\n'.join(lines)


def fail(prog, message):
    """Print `prog: message` as one line on stderr and exit with status 2 (bad input)."""
    print(f'{prog}: {message}', file=sys.stderr)
    sys.exit(2)


def handle_command_line(prog, doc, params, args=None):
    """
    Answer `-h`/`--help` (print the parameters, exit 0) and refuse stray arguments.

    Runs before rclpy starts, so help starts no node, writes nothing and opens no port.
    Any argument outside `--ros-args ... [--]` other than -h/--help ends with exit 2.
    `args` excludes the program name; None: sys.argv[1:].
    """
    argv = sys.argv[1:] if args is None else list(args)
    try:
        rest = remove_ros_args(['prog'] + argv)[1:]
    except Exception as err:   # noqa: B902 - rcl's error type is in a private module
        fail(prog, f'bad --ros-args: {_rcl_message(err)}')
    if '-h' in rest or '--help' in rest:
        print(parameter_help(prog, doc, params))
        sys.exit(0)
    if rest:
        fail(prog, f'unrecognised arguments {rest}; parameters go after --ros-args: '
                   f'{prog} --ros-args -p NAME:=VALUE (see {prog} --help)')


def create_node(prog, node_class, args=None, **kwargs):
    """
    Return `node_class(**kwargs)`, then warn about parameters it does not use.

    A ParameterError from the constructor ends in one line on stderr and exit status 2:
    the node is not started (nothing published, no port opened, no file written).
    """
    try:
        node = node_class(**kwargs)
    except ParameterError as err:
        fail(prog, str(err))
    warn_parameter_sources(node, args)
    return node


def _rcl_message(err):
    """Return rcl's error text without its source locations."""
    return re.sub(r',? at /\S+:\d+', '', str(err).strip().splitlines()[0])


def warn_parameter_sources(node, args=None):
    """
    Warn about parameters the node does not declare and params files with nothing for it.

    Reads the `--ros-args` of the command line (`args` without the program name; None:
    sys.argv[1:]): every `-p [node:]name:=value` and every `--params-file FILE`. A file
    section applies to the node when its key matches the node's fully qualified name as
    rcl matches it (a relative key gets a leading /, `*` is one name, `/**` any
    namespace). Returns the warnings (also logged).
    """
    argv = sys.argv[1:] if args is None else list(args)
    fqn = node.get_fully_qualified_name()
    known = set(node.__dict__.get('_sma_parameters', {})) | set(RCLPY_PARAMETERS)
    warnings, unknown = [], {}
    files, given = _ros_parameter_arguments(argv)
    for path in files:
        try:
            with open(path) as f:
                sections = _param_sections(yaml.safe_load(f))
        except (OSError, yaml.YAMLError):
            continue   # rcl read it already; nothing more to say here
        mine = [values for key, values in sections if _node_matches(key, fqn)]
        if not mine:
            keys = ', '.join(key for key, _ in sections) or 'none'
            warnings.append(f'params file {path} holds no parameters for node {fqn}; keys '
                            f'found: {keys}')
        for values in mine:
            for name in values:
                unknown.setdefault(name, f'params file {path}')
    for target, name in given:
        if target is None or _node_matches(target, fqn):
            unknown.setdefault(name, '-p')
    unknown = {k: v for k, v in unknown.items() if k not in known}
    if unknown:
        named = ', '.join(f'{k} ({v})' for k, v in sorted(unknown.items()))
        warnings.append(f'ignoring parameters that node {fqn} does not declare: {named}; '
                        'see --help')
    for text in warnings:
        node.get_logger().warning(text)
    return warnings


def _ros_parameter_arguments(argv):
    """Return (params files, [(node or None, name)]) from the --ros-args sections."""
    files, given, inside, i = [], [], False, 0
    while i < len(argv):
        a = argv[i]
        if a == '--ros-args':
            inside = True
        elif a == '--':
            inside = False
        elif inside and a == '--params-file' and i + 1 < len(argv):
            files.append(argv[i + 1])
            i += 1
        elif inside and a in ('-p', '--param') and i + 1 < len(argv):
            rule = argv[i + 1].split(':=', 1)[0]
            target, _, name = rule.rpartition(':')
            given.append((target or None, name))
            i += 1
        i += 1
    return files, given


def _param_sections(doc, prefix=''):
    """Return [(node key, {flattened parameter name: value})] of a params YAML document."""
    out = []
    for key, value in (doc or {}).items() if isinstance(doc, dict) else ():
        if not isinstance(value, dict):
            continue
        path = f'{prefix}/{str(key).strip("/")}' if prefix else str(key)
        if 'ros__parameters' in value:
            out.append((path, _flatten(value['ros__parameters'])))
        else:
            out.extend(_param_sections(value, path))
    return out


def _flatten(params, prefix=''):
    out = {}
    for key, value in (params or {}).items() if isinstance(params, dict) else ():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            out.update(_flatten(value, name + '.'))
        else:
            out[name] = value
    return out


def _node_matches(key, fqn):
    """Return whether a params-file node key (`/sma/controller`, `/**`, `*`...) names fqn."""
    key = key if key.startswith('/') else '/' + key
    pattern = re.escape(key).replace(r'/\*\*', r'(/\w+)*').replace(r'\*', r'\w+')
    return re.fullmatch(pattern, fqn) is not None


def stamp_to_s(stamp):
    """builtin_interfaces/Time -> seconds (float)."""
    return stamp.sec + 1e-9 * stamp.nanosec


def config_path(name):
    """Path of a file in the package's config/: the installed share dir, else the source tree."""
    try:
        from ament_index_python.packages import get_package_share_directory
        p = Path(get_package_share_directory('sma_actuator')) / 'config' / name
        if p.exists():
            return p
    except Exception:   # not on an ament index (plain venv): fall back to the source tree
        pass
    return Path(__file__).resolve().parents[2] / 'config' / name


class Diagnostics:
    """Publishes one DiagnosticStatus (`<node>: <name>`) on /diagnostics."""

    def __init__(self, node, name, hardware_id=None):
        self.node = node
        self.name = f'{node.get_name()}: {name}'
        # the node's full name tells two actuators (namespaces) apart on the one /diagnostics
        self.hardware_id = hardware_id or node.get_fully_qualified_name()
        self.pub = node.create_publisher(DiagnosticArray, DIAGNOSTICS, DIAGNOSTICS_QOS)

    def publish(self, level, message, values=None, stamp=None):
        """Send level (OK/WARN/ERROR), message and key values (str() of each value)."""
        msg = DiagnosticArray()
        msg.header.stamp = stamp or self.node.get_clock().now().to_msg()
        status = DiagnosticStatus(level=level, name=self.name, message=message,
                                  hardware_id=self.hardware_id)
        status.values = [KeyValue(key=k, value=_fmt(v)) for k, v in (values or {}).items()]
        msg.status = [status]
        self.pub.publish(msg)


def _fmt(v):
    return f'{v:.6g}' if isinstance(v, float) else str(v)
