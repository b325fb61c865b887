"""
Hardware side of the actuator: serial protocol, MCU logic, serial link and MCU emulator.

- protocol.py: COBS framing, CRC-32 and the messages (the one Python implementation).
- mcu_core.py: the microcontroller's logic (twin of firmware/sma_mcu/sma_mcu_core.cpp).
- link.py: pyserial port owner with reconnect and backoff.
- bridge_core.py, calibration.py: the ROS-free logic of the hardware_bridge node.
- emulator.py: MCU emulator on a pseudo-terminal or TCP socket, with the simulated plant.
- vectors.py: writes/checks firmware/test_vectors.json shared with the C++ firmware.
"""
