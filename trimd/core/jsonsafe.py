"""Numbers for strict JSON: an undefined number (NaN, ±inf) is written as ``null``.

Python's ``json`` writes NaN as the non-standard token ``NaN``, which other tools (jq,
JavaScript, sqlite's json functions) refuse; trimd's reports, fragments and history say
"undefined" with ``null`` instead.
"""

from __future__ import annotations

import math

__all__ = ["json_finite", "json_number"]


def json_number(value: float) -> float | None:
    """``value``, or None where it is undefined (NaN or infinite)."""
    return value if math.isfinite(value) else None


def json_finite(value: object) -> object:
    """``value`` (numbers, dicts, lists, tuples, nested) with every NaN or infinite float
    replaced by None."""
    if isinstance(value, float):
        return json_number(value)
    if isinstance(value, dict):
        return {k: json_finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_finite(v) for v in value]
    return value
