"""Re-export of :mod:`trimd.samples` (the sample and command values live in the core so
that the pure procedure can use them without importing a driver)."""

from trimd.samples import *  # noqa: F403
from trimd.samples import __all__ as __all__
