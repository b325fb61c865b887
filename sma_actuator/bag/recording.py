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

"""Recorder logic without ROS: which topics to record and where the bag goes."""
from datetime import datetime
import fnmatch
from pathlib import Path
import re
from typing import Iterable, Optional, Union

#: Topics recorded by default: everything in the recorder's namespace (``/sma`` by default)
#: and the diagnostics.
DEFAULT_TOPICS = ('*', '/diagnostics')
#: Default bag directory name: run name plus local start time, like rosbag2's default.
DEFAULT_NAME_TEMPLATE = '{run_name}_{date:%Y_%m_%d-%H_%M_%S}'
_SAFE_NAME = re.compile(r'^[A-Za-z0-9._-]+$')


class TopicSelector:
    """
    Decide which topics to record from names and glob patterns (``/sma/*``).

    :param patterns: Topic names or fnmatch patterns; ``*`` also matches ``/``. A relative
        pattern (``*``, ``duty``) is resolved in ``namespace``, as ROS resolves topic names.
    :param namespace: Absolute namespace of the recorder node (``/sma``, ``/``).
    :raises ValueError: No pattern, a pattern with ``~`` or a namespace that is not absolute.
    """

    def __init__(self, patterns: Iterable[str], namespace: str = '/') -> None:
        if patterns is None or isinstance(patterns, (str, bytes)) or not all(
                isinstance(p, str) for p in patterns):
            # `topics:=[]` on the command line arrives untyped (None): an empty selection
            raise ValueError(f'topics must be a list of topic names or patterns, got '
                             f'{patterns!r}: give at least one (default {list(DEFAULT_TOPICS)})')
        if not namespace.startswith('/'):
            raise ValueError(f'namespace must be absolute (start with /): {namespace!r}')
        given = [p.strip() for p in patterns if p and p.strip()]
        if not given:
            raise ValueError('no topics to record: give at least one topic name or pattern '
                             f'(default {list(DEFAULT_TOPICS)})')
        bad = [p for p in given if p.startswith('~')]
        if bad:
            raise ValueError(f'private (~) topic patterns are not supported: {bad}')
        prefix = namespace.rstrip('/') + '/'
        self.patterns = [p if p.startswith('/') else prefix + p for p in given]

    def matches(self, topic: str) -> bool:
        """Return True if ``topic`` is to be recorded."""
        return any(fnmatch.fnmatchcase(topic, p) for p in self.patterns)


def bag_directory(output_dir: Union[str, Path], run_name: str,
                  name_template: str = DEFAULT_NAME_TEMPLATE,
                  now: Optional[datetime] = None) -> Path:
    """
    Return the bag directory ``output_dir/<name>`` with the name made from a template.

    :param name_template: ``str.format`` template with fields ``run_name`` and ``date`` (a
        datetime, so ``{date:%Y%m%d}`` works).
    :param now: Time put in ``date``; default: local now.
    :raises ValueError: Unknown template field, or a name that is empty or holds characters
        other than letters, digits, ``.``, ``_`` and ``-`` (keeps names portable and stops a
        run name from escaping ``output_dir``).
    """
    try:
        name = name_template.format(run_name=run_name, date=now or datetime.now())
    except (KeyError, IndexError, ValueError) as err:
        raise ValueError(f"bad bag name template '{name_template}': {err!r} (fields: "
                         '{run_name}, {date:<strftime format>})') from err
    if not _SAFE_NAME.match(name) or name in ('.', '..'):
        raise ValueError(f"bag name '{name}' (from template '{name_template}' and run name "
                         f"'{run_name}') may only hold letters, digits, '.', '_' and '-'")
    return Path(output_dir) / name
