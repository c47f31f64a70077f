"""The one error of foos_bag, and the one-line form every message of it takes."""
from __future__ import annotations

__all__ = ["BagError", "first_line"]


class BagError(Exception):
    """A bag cannot be written or read; the message is one line meant for the user."""


def first_line(exc: BaseException) -> str:
    """An exception's message cut to its first line, or its type's name when it has none (rosbags, sqlite
    and struct errors from damaged files come both ways)."""
    text = str(exc)
    return text.splitlines()[0] if text else type(exc).__name__
