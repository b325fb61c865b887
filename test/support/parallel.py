"""The package's process pool, for the hidden-effect tests and benchmark (one record per core)."""
from sma_actuator.workbench.parallel import imap_on_cores  # noqa: F401
