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
Errors raised by the bag library.

Every error is a ValueError subclass whose message starts with the file (or directory) it is
about, so a caller can catch ``BagError`` (or plain ``ValueError``) and show the message as is.
"""
from pathlib import Path
from typing import Optional, Union


class BagError(ValueError):
    """
    A bag (or a file in it) cannot be written or read as asked.

    :param path: The bag directory or file the problem is about.
    :param problem: What is wrong, in words a user can act on.
    """

    def __init__(self, path: Optional[Union[str, Path]], problem: str) -> None:
        self.path = None if path is None else Path(path)
        self.problem = problem
        super().__init__(problem if path is None else f'{path}: {problem}')


class BagNotFoundError(BagError):
    """The path does not exist, or a bag directory holds no .mcap file."""


class NotMcapError(BagError):
    """The file is not an MCAP file (wrong magic bytes)."""


class TruncatedBagError(BagError):
    """The file is empty or cut off before its first complete chunk: nothing can be recovered."""


class DamagedBagError(BagError):
    """A file's data is damaged where it cannot be recovered (the message gives the offset)."""


class UnknownTypeError(BagError):
    """A message type is unknown: no installed definition, or an unexpected type on a topic."""


class MissingTopicError(BagError):
    """A topic that is required is not in the bag (or has no messages)."""


class BagExistsError(BagError):
    """Writing would overwrite an existing bag and overwriting was not asked for."""


class BagWriteError(BagError):
    """A write call is invalid (unknown topic, bad timestamp, writer already closed)."""
