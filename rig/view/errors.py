"""What the view answers a request it cannot (``ViewError``: an HTTP status and one line), and a
request's whole-number parameter checked (``whole_number``)."""

from __future__ import annotations

__all__ = ["ViewError", "whole_number"]


class ViewError(Exception):
    """A request the view cannot answer: its HTTP status and one line saying why.

    Parameters
    ----------
    status : int
        The HTTP status.
    text : str
        Why.
    """

    def __init__(self, status: int, text: str) -> None:
        super().__init__(text)
        self.status = status


def whole_number(value: str | None, name: str, default: int, low: int, high: int) -> int:
    """A request's whole-number parameter within [``low``, ``high``].

    Parameters
    ----------
    value : str | None
        As the request spells it (None or "": ``default``).
    name : str
        The parameter's, named in an error.
    default : int
        Where it is not given.
    low, high : int
        Its bounds.

    Returns
    -------
    int
        The number.

    Raises
    ------
    ViewError
        400, naming it, if it is not a whole number within the bounds.
    """
    if value is None or value == "":
        return default
    if len(value) > 12 or not value.isdigit():
        raise ViewError(400, f"{name}: {value[:20]!r} is not a whole number")
    n = int(value)
    if not low <= n <= high:
        raise ViewError(400, f"{name}: {n} is not within {low}..{high}")
    return n
