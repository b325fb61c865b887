"""
ROS-free control logic of the actuator (unit-tested without ROS; the nodes are thin wrappers).

* `pi`: discrete PI with anti-windup (the paper's 25 ms PI).
* `split`: antagonistic split of a signed command into two wire duties.
* `estimator`: wire temperature/contraction estimate from the core model.
* `guard`: thermal guard (duty limits from the estimated temperatures).
* `feedforward`: inverse compensation H^-1 + static thermal map (mode `pi_inverse`).
* `on_off`: the paper's fully-heated / fully-cooled relay mode.
* `core`: `ControllerCore`, the three modes assembled into one step function.
* `inputs`: validation of setpoints and duties (reject, keep the last valid value).
* `metrics`: rms / max error and settling time of a tracking run.
* `excitation`: open-loop duty sequences for identification runs.
"""
