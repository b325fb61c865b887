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
Hardware side of the actuator: serial protocol, MCU logic, serial link and MCU emulator.

- protocol.py: COBS framing, CRC-32 and the messages (the one Python implementation).
- mcu_core.py: the microcontroller's logic (twin of firmware/sma_mcu/sma_mcu_core.cpp).
- link.py: pyserial port owner with reconnect and backoff.
- bridge_core.py, calibration.py: the ROS-free logic of the hardware_bridge node.
- emulator.py: MCU emulator on a pseudo-terminal or TCP socket, with the simulated plant.

The firmware test vectors (firmware/test_vectors.json) are written by
test/support/firmware_vectors.py, outside the runtime package.
"""
