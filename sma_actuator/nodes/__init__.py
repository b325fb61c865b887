"""
ROS 2 nodes (thin wrappers around the core and sma_actuator.control).

plant_sim: simulated actuator; controller: pi / pi_inverse / on_off; setpoint: profiles.
`common` holds the topic names, QoS profiles, parameter-descriptor and diagnostics helpers
they share.
"""
