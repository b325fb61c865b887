"""sma_actuator: antagonistic SMA wire actuator software (see README.md)."""
__version__ = '0.1.0'
