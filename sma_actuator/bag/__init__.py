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
Recording and replay support: rosbag2-compatible MCAP bags without rosbag2 (ROS-free).

- :mod:`.writer`: :class:`BagWriter`, serialized messages -> bag directory (MCAP + metadata.yaml)
- :mod:`.reader`: :class:`BagReader`, bag -> messages/topics, recovers unfinished files
- :mod:`.arrays`: :func:`load_run`, bag -> aligned numpy arrays for the model workbench
- :mod:`.msgdefs`, :mod:`.qos`, :mod:`.metadata`: rosbag2 conventions (definitions, QoS YAML,
  metadata.yaml)
- :mod:`.playback`: timing of replay (used by the replay node)
- :mod:`.errors`: the ValueError subclasses raised for bad input

See docs/recording.md.
"""
from .errors import (BagError, BagExistsError, BagNotFoundError, BagWriteError,
                     MissingTopicError, NotMcapError, TruncatedBagError, UnknownTypeError)
from .reader import BagMessage, BagReader, RecoveryReport, TopicInfo
from .writer import BagWriter

__all__ = [
    'BagError', 'BagExistsError', 'BagMessage', 'BagNotFoundError', 'BagReader', 'BagWriteError',
    'BagWriter', 'MissingTopicError', 'NotMcapError', 'RecoveryReport', 'TopicInfo',
    'TruncatedBagError', 'UnknownTypeError',
]
