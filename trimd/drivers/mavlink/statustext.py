"""STATUSTEXT's text field: 50 bytes a message, longer texts in chunks (MAVLink 2).

A text of more than 50 bytes goes out as several STATUSTEXT messages with the same
non-zero ``id`` and ``chunk_seq`` 0, 1, …; a chunk shorter than 50 bytes ends it, so a
text whose last chunk is full gets an empty one after it. Ground stations built on
pymavlink (MAVProxy) decode the field as ASCII: :func:`ascii_text` spells trimd's few
non-ASCII signs out before a text goes on the network.
"""

from __future__ import annotations

__all__ = ["STATUSTEXT_BYTES", "ascii_text", "text_chunks"]

#: Bytes of text one STATUSTEXT carries.
STATUSTEXT_BYTES = 50

_SPELLED = {"±": "+-", "°": "deg", "−": "-", "–": "-", "—": "-", "·": "*", "×": "x",
            "…": "...", "σ": "sd", "²": "^2", "µ": "u"}


def ascii_text(text: str) -> str:
    """``text`` with trimd's non-ASCII signs spelled out and anything else as ``?``.

    Examples
    --------
    >>> ascii_text("W − B 2.4 ± 0.1 N at roll 10°")
    'W - B 2.4 +- 0.1 N at roll 10deg'
    """
    out = "".join(_SPELLED.get(c, c) for c in text)
    return out.encode("ascii", "replace").decode("ascii")


def text_chunks(text: str) -> list[bytes]:
    """Split ``text`` (UTF-8) into STATUSTEXT chunks of 50 bytes and a shorter last one
    (an empty one after a full last chunk of several); a non-ASCII character may
    straddle two chunks (join the bytes, then decode).

    Examples
    --------
    >>> [len(c) for c in text_chunks("x" * 120)]
    [50, 50, 20]
    >>> [len(c) for c in text_chunks("x" * 100)]
    [50, 50, 0]
    >>> text_chunks("short")
    [b'short']
    """
    data = text.encode("utf-8")
    chunks = [data[i:i + STATUSTEXT_BYTES] for i in range(0, len(data), STATUSTEXT_BYTES)]
    if not chunks or (len(chunks) > 1 and len(chunks[-1]) == STATUSTEXT_BYTES):
        chunks.append(b"")
    return chunks
