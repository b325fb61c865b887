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
The console-script side of every node: ``--help``, bad input, parameter sources, stop signals.

A node's ``main`` runs :func:`handle_command_line` (help and stray arguments, before rclpy
starts), :func:`init_with_stop_signals`, :func:`create_node` (a bad parameter: one line on
stderr, exit status 2) and :func:`spin_until_stopped`.
"""
import faulthandler
import os
import re
import signal
import sys
import threading
from typing import Any, Callable, Dict, Iterable, List, NoReturn, Optional, Sequence, Tuple

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args
import yaml

from .ros_params import declared_names, Param, ParameterError, RCLPY_PARAMETERS


# a node still alive this long after its stop signal is hung (in DDS teardown, say)
STOP_GRACE_S = 10.0


def install_stop_signals(grace_s: Optional[float] = None) -> threading.Event:
    """
    SIGINT and SIGTERM set the returned Event and raise nothing.

    Why not rclpy's handler: it chains to Python's default SIGINT handler, and the
    KeyboardInterrupt it raises can land inside a pybind11 call of the executor
    (`take_message`), which turns it into "RuntimeError: Unable to convert call argument"
    and exit status 1 (ros/joint_state_publisher#117; seen here under load). A flag that the
    spin loop polls stops every node between callbacks, with its context still valid, so
    the shutdown path can still publish a zero duty.

    With `grace_s`, the first signal also starts :func:`exit_if_still_running_after`.
    """
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    if grace_s is not None:
        exit_if_still_running_after(grace_s)
    return stop


def exit_if_still_running_after(grace_s: float) -> None:
    """
    From the first SIGINT/SIGTERM on, allow the process `grace_s` seconds [s] to exit.

    Past that, faulthandler prints every thread's stack to stderr and ends the process with
    status 1, instead of a hung teardown waiting for its launcher's SIGKILL. Python runs
    signal handlers only in the main thread, between bytecodes: a main thread blocked in
    C code never runs them. The wakeup pipe is written by the C-level handler itself, so a
    helper thread sees the signal anyway, and faulthandler's timer thread needs no GIL.
    Call from the main thread.
    """
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)

    def arm_on_signal() -> None:
        os.read(read_fd, 1)
        faulthandler.dump_traceback_later(grace_s, exit=True)
    threading.Thread(target=arm_on_signal, name='stop_grace', daemon=True).start()


def init_with_stop_signals(args: Optional[Sequence[str]] = None,
                           prog: Optional[str] = None) -> threading.Event:
    """
    Run `rclpy.init(args)` without rclpy's signal handlers; return `install_stop_signals()`.

    The stop signals come with a grace of STOP_GRACE_S [s] (:func:`exit_if_still_running_after`).

    With `prog`, a command line rcl cannot parse (a malformed `-p`, an unreadable params
    file) ends in one line on stderr and exit status 2 instead of a traceback.
    """
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except Exception as err:   # noqa: B902 - rcl's error type is in a private module
        if prog is None:
            raise
        fail(prog, f'cannot start: {_rcl_message(err)}')
    return install_stop_signals(STOP_GRACE_S)


def spin_until_stopped(node: Node, stop: threading.Event,
                       done: Optional[Callable[[], bool]] = None,
                       poll_s: float = 0.05) -> SingleThreadedExecutor:
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


def parameter_help(prog: str, doc: Optional[str], params: Iterable[Param]) -> str:
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


def fail(prog: str, message: str) -> NoReturn:
    """Print `prog: message` as one line on stderr and exit with status 2 (bad input)."""
    print(f'{prog}: {message}', file=sys.stderr)
    sys.exit(2)


def handle_command_line(prog: str, doc: Optional[str], params: Iterable[Param],
                        args: Optional[Sequence[str]] = None) -> None:
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


def create_node(prog: str, node_class: Callable[..., Node],
                args: Optional[Sequence[str]] = None, **kwargs: Any) -> Node:
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


def _rcl_message(err: Exception) -> str:
    """Return rcl's error text without its source locations."""
    return re.sub(r',? at /\S+:\d+', '', str(err).strip().splitlines()[0])


def warn_parameter_sources(node: Node, args: Optional[Sequence[str]] = None) -> List[str]:
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
    known = set(declared_names(node)) | set(RCLPY_PARAMETERS)
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


def _ros_parameter_arguments(
        argv: Sequence[str]) -> Tuple[List[str], List[Tuple[Optional[str], str]]]:
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


def _param_sections(doc: Any, prefix: str = '') -> List[Tuple[str, Dict[str, Any]]]:
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


def _flatten(params: Any, prefix: str = '') -> Dict[str, Any]:
    out = {}
    for key, value in (params or {}).items() if isinstance(params, dict) else ():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            out.update(_flatten(value, name + '.'))
        else:
            out[name] = value
    return out


def _node_matches(key: str, fqn: str) -> bool:
    """Return whether a params-file node key (`/sma/controller`, `/**`, `*`...) names fqn."""
    key = key if key.startswith('/') else '/' + key
    pattern = re.escape(key).replace(r'/\*\*', r'(/\w+)*').replace(r'\*', r'\w+')
    return re.fullmatch(pattern, fqn) is not None
