"""The type aliases every layer shares: numpy arrays of floats, 3-vectors, JSON objects."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["FloatArray", "JsonObject", "Vec3"]

#: An array of float64 (any shape; the docstring says which).
FloatArray = NDArray[np.float64]
#: A 3-vector as a tuple (x, y, z), e.g. a position [m] in the body frame.
Vec3 = tuple[float, float, float]
#: A JSON object as json.loads gives it and json.dumps takes it.
JsonObject = dict[str, Any]
