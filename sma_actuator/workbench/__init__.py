"""
Model workbench: compare the actuator model with measurements, find the missing effect.

Modules (see docs/workbench.md for the user walkthrough):

* `data`      – load DATA: dynamic CSV, static curve CSV or MCAP bag, with clear errors
* `engine`    – fit a model with a set of effects, diagnose which effect is missing
* `effects`   – the effect catalog (`CATALOG`, `Effect`, `register_effect`)
* `compare`   – error breakdown by regime and residual correlation tests
* `report`    – HTML report with PNG figures
* `modelfile` – MODEL.yaml read/write
* `plugins`   – user effects from a file, a module or the `sma_actuator.effects` entry points
* `cli`       – the `sma-model` command

Submodules are imported on use, so `import sma_actuator.workbench` stays cheap.
"""
