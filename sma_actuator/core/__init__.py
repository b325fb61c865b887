"""
Pure numerical core (no ROS): hysteresis operators, thermal dynamics, actuator, identification.

Equation numbers refer to Solc & Vasina, "Modeling and Control of SMA Actuator"
(shared/reference): (1)-(2) cosine main loop, (3)-(4) Preisach, (5) Prandtl-Ishlinskii,
(6) modified PI (backlash with saturation), (7) wire thermal dynamics.
"""
