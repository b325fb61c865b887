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
What the nodes' /diagnostics say about the duty a bag logs: commands not applied as sent.

The recorder logs each duty command as sent. The hardware bridge (and plant_sim) holds a
command that heats one wire within the dead time after the other was heated, and the
bridge clamps one above its max_duty; both count them in their ``duty`` status on
/diagnostics (``interlock_held``, ``clamped``). A model fitted to the logged commands then
sees heating the wires never got, so the workbench says how many there were. The bridge
also publishes the duty it applied (``applied_duty``); a bag that holds it is loaded from
it, and the note says so.
"""
from pathlib import Path
from typing import Dict, Iterable, List, Optional, Tuple

from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
import numpy as np

from .reader import BagReader

DIAGNOSTICS = '/diagnostics'
DIAGNOSTIC_ARRAY = 'diagnostic_msgs/msg/DiagnosticArray'
#: counter key of a duty status -> what the note says of the commands it counts
ALTERED = {'interlock_held': 'held {n} duty command{s} at the dead-time interlock',
           'clamped': 'clamped {n} to max_duty'}


def counted(values: Iterable[float]) -> int:
    """
    Return the count a cumulative counter gained over its readings, in order.

    The sum of its rises; a fall is a restart of the node, after which it counts from 0.
    """
    v = np.asarray(list(values), dtype=float)
    steps = np.diff(v)
    return int(np.sum(np.where(steps >= 0, steps, v[1:])))


def _counter_readings(reader: BagReader, info) -> Dict[Tuple[str, str], Dict[str, List[float]]]:
    """Return {(status name, hardware_id): {counter key: readings in log order}}."""
    schema = Schema(id=1, name=info.type, encoding='ros2msg', data=info.definition.encode())
    decode = DecoderFactory().decoder_for('cdr', schema)
    readings = {}
    for msg in reader.messages(topics=[DIAGNOSTICS]):
        for status in decode(msg.data).status:
            for kv in status.values:
                if kv.key not in ALTERED:
                    continue
                try:
                    value = float(kv.value)
                except ValueError:
                    continue
                source = readings.setdefault((status.name, status.hardware_id), {})
                source.setdefault(kv.key, []).append(value)
    return readings


def altered_duty_notes(reader: BagReader, path: Path, duty_topic: str,
                       applied_topic: Optional[str] = None) -> List[str]:
    """
    Return one line per node whose /diagnostics count duty commands it did not apply as sent.

    Counts are the rises of each status's ``interlock_held`` and ``clamped`` counters over
    the bag (`counted`); commands altered before the first /diagnostics message of the bag
    are not seen. A /diagnostics topic that cannot be decoded gives one line saying so.
    `applied_topic`: the topic the duty is loaded from instead of the commands, if any.
    """
    info = reader.topics.get(DIAGNOSTICS)
    if (info is None or info.message_count == 0 or info.type != DIAGNOSTIC_ARRAY
            or info.schema_encoding != 'ros2msg' or info.serialization_format != 'cdr'):
        return []
    try:
        readings = _counter_readings(reader, info)
    except Exception as err:  # noqa: BLE001 - the duty is loaded all the same
        return [f'{path}: {DIAGNOSTICS} cannot be decoded ({type(err).__name__}), so whether '
                f'a node held or clamped the commands on {duty_topic} is not known']
    notes = []
    for (name, hardware_id), counters in sorted(readings.items()):
        said = [ALTERED[key].format(n=n, s='' if n == 1 else 's') for key, n in
                ((k, counted(v)) for k, v in counters.items()) if n > 0]
        if said:
            tail = (f'{duty_topic} logs them as sent, not as applied' if applied_topic is None
                    else f'the duty is read from {applied_topic}, as applied')
            notes.append(f'{path}: {name} ({hardware_id}) {" and ".join(said)} while recorded: '
                         f'{tail}')
    return notes
