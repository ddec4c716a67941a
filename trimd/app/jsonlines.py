"""What ``--json`` prints: one JSON object per line, each with its ``type``
(docs/operator.md, "JSON output").

Strict JSON: a number that is not finite (NaN, ±inf, which Python's ``json`` would print
as the non-JSON ``NaN`` and ``Infinity``) becomes null
(:func:`trimd.core.jsonsafe.json_finite`).
"""

from __future__ import annotations

import json
import sys
from typing import Any, TextIO

from trimd.core.jsonsafe import json_finite

__all__ = ["error_line", "json_line", "print_json", "print_result"]


def json_line(obj: dict[str, Any]) -> str:
    """``obj`` as one line of strict JSON."""
    return json.dumps(json_finite(obj), allow_nan=False)


def print_json(obj: dict[str, Any], stream: TextIO | None = None) -> None:
    """Print ``obj`` as one line of strict JSON to ``stream`` (default: the standard
    output of the moment), flushed: a reader sees each line as it comes."""
    print(json_line(obj), file=stream or sys.stdout, flush=True)


def print_result(as_json: bool, obj: dict[str, Any], text: str) -> None:
    """A command's answer on stdout: ``obj`` as a JSON line, or ``text`` for people."""
    if as_json:
        print_json(obj)
    else:
        print(text)


def error_line(message: str, exit_code: int) -> dict[str, Any]:
    """The line that ends the output of a command that stopped on an error."""
    return {"type": "error", "message": message, "exit_code": exit_code}
