"""What ``rig identify`` raises where the data cannot identify the model."""

from __future__ import annotations

__all__ = ["IdentificationError"]


class IdentificationError(ValueError):
    """The data cannot identify the model; the message says why."""
