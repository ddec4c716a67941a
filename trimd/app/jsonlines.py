"""What ``--json`` prints: one JSON object per line, each with its ``type``
(docs/operator.md, "JSON output").

Strict JSON: a number that is not finite (NaN, ±inf, which Python's ``json`` would print
as the non-JSON ``NaN`` and ``Infinity``) becomes null.
"""

from __future__ import annotations

import json
import math
import sys
from typing import Any, TextIO

__all__ = ["error_line", "json_line", "print_json"]


def _strict(x: Any) -> Any:
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _strict(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_strict(v) for v in x]
    return x


def json_line(obj: dict[str, Any]) -> str:
    """``obj`` as one line of strict JSON."""
    return json.dumps(_strict(obj), allow_nan=False)


def print_json(obj: dict[str, Any], stream: TextIO | None = None) -> None:
    """Print ``obj`` as one line of strict JSON to ``stream`` (default: the standard
    output of the moment), flushed: a reader sees each line as it comes."""
    print(json_line(obj), file=stream or sys.stdout, flush=True)


def error_line(message: str, exit_code: int) -> dict[str, Any]:
    """The line that ends the output of a command that stopped on an error."""
    return {"type": "error", "message": message, "exit_code": exit_code}
