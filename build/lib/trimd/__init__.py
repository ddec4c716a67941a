"""trimd: measure an underwater vehicle's centre of gravity and extra mass, propose ballast.

The core modules (``profile``, ``model``, ``estimate``, ``resample``, ``steady``) are
pure computation in SI units, body frame FRD and world frame NED (Fossen 2011).
"""

__version__ = "0.1.0"
