"""Time profiles written as text: a load torque [N m] or a reference of time t [s].

A profile is a sum of terms separated by ``+``; each term is ``kind:args``
with numbers as arguments (negative allowed, and exponents such as ``1e+3``):

- ``none``: 0;
- ``const:A``: A;
- ``step:A:t0``: A for t >= t0, else 0 (A h(t - t0) with the unit step h);
- ``pulse:A:t0:t1``: A for t0 <= t < t1, else 0 (A [h(t - t0) - h(t - t1)]);
- ``sine:A:f`` and ``sine:A:f:t0``: A sin(2 pi f t) for t >= t0 (default 0), else 0;
  the phase is that of absolute time t, not of t - t0.

So the drives paper's load of section VII.D, T_L = 5 [h(t-2) - h(t-4) + h(t-8) sin(4 pi t)],
is ``pulse:5:2:4 + sine:5:2:8``, and 5 sin(2 pi t) of section VII.C is ``sine:5:1``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable

__all__ = ["Profile", "parse_profile", "profile_peak"]

Profile = Callable[[float], float]

_PLUS = re.compile(r"(?<![\d.][eE])\+")  # a "+" that is not an exponent's sign
_ARITY = {"none": (0,), "const": (1,), "step": (2,), "pulse": (3,), "sine": (2, 3)}


def _zero(t: float) -> float:
    return 0.0


def _term(kind: str, a: list[float]) -> Profile:
    """The function of one checked term."""
    if kind == "none":
        return _zero
    amp = a[0]
    if kind == "const":
        return lambda t: amp
    if kind == "step":
        t0 = a[1]
        return lambda t: amp if t >= t0 else 0.0
    if kind == "pulse":
        t0, t1 = a[1], a[2]
        return lambda t: amp if t0 <= t < t1 else 0.0
    w, start = 2.0 * math.pi * a[1], a[2] if len(a) == 3 else -math.inf
    return lambda t: amp * math.sin(w * t) if t >= start else 0.0


def _parse_term(term: str) -> Profile:
    """One ``kind:args`` term; ValueError saying what is wrong with it."""
    kind, *args = (part.strip() for part in term.split(":"))
    if kind not in _ARITY:
        raise ValueError(f"unknown kind {kind!r}; use none, const:A, step:A:t0, pulse:A:t0:t1, sine:A:f[:t0]")
    if len(args) not in _ARITY[kind]:
        counts = " or ".join(str(n) for n in _ARITY[kind])
        raise ValueError(f"{kind} takes {counts} numbers, got {len(args)}")
    try:
        nums = [float(a) for a in args]
    except ValueError:
        raise ValueError("arguments must be numbers") from None
    if not all(math.isfinite(x) for x in nums):
        raise ValueError("arguments must be finite")
    if kind == "pulse" and not nums[2] > nums[1]:
        raise ValueError(f"a pulse needs t1 > t0, got t0 = {nums[1]:g}, t1 = {nums[2]:g}")
    return _term(kind, nums)


def parse_profile(text: str) -> Profile:
    """The profile written in ``text`` (see the module docstring) as a function of t [s].

    A ValueError names the faulty term and the whole text.

    Parameters
    ----------
    text : str
        The profile, e.g. ``step:0.5:0.1+sine:0.2:5``.

    Returns
    -------
    Profile
        t [s] -> its value.

    Raises
    ------
    ValueError
        If a term is malformed (the term and the whole text named).
    """
    terms = []
    for raw in _PLUS.split(text):
        term = raw.strip()
        try:
            if not term:
                raise ValueError("empty term")
            terms.append(_parse_term(term))
        except ValueError as exc:
            raise ValueError(f"profile {text!r}: term {term!r}: {exc}") from None
    live = [f for f in terms if f is not _zero]
    if not live:
        return _zero
    if len(live) == 1:
        return live[0]
    return lambda t: sum(f(t) for f in live)


def profile_peak(text: str) -> float:
    """The most |value| the profile written in ``text`` can take: the sum of its terms' |A|
    (0 for none); a ValueError as ``parse_profile``'s where it is not a profile.

    Parameters
    ----------
    text : str
        The profile.

    Returns
    -------
    float
        The sum of its terms' amplitudes |A|.
    """
    parse_profile(text)
    return sum(abs(float(part.split(":")[1])) for part in _PLUS.split(text) if ":" in part)
