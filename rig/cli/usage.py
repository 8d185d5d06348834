"""A command line's usage error and the parser that raises it: one line naming the argument,
never argparse's exit; a help text made when first read (``Lazy``)."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any, NoReturn

__all__ = ["Lazy", "Parser", "UsageError"]


class UsageError(Exception):
    """A command-line argument is wrong; the message names it."""


class Lazy:
    """A help text made when it is first read (``Parser.description``): a text that needs a heavy
    module (numpy, a paper's study) costs nothing to a command that does not show it.

    Parameters
    ----------
    make : Callable[[], str]
        Makes the text.
    """

    def __init__(self, make: Callable[[], str]) -> None:
        self.make = make


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line, raised instead of exiting; its description may be
    ``Lazy``, made when read; a repeatable option given before and after an action keeps both
    (``rig.cli.language.MergingSubParsers``).

    Parameters
    ----------
    *args : Any
        ``argparse.ArgumentParser``'s.
    **kw : Any
        ``argparse.ArgumentParser``'s.
    """

    _text: str | Lazy | None = None  #: the description as given: made on first read if Lazy

    def __init__(self, *args: Any, **kw: Any) -> None:
        from rig.cli.language import MergingSubParsers

        super().__init__(*args, **kw)
        self.register("action", "parsers", MergingSubParsers)

    @property
    def description(self) -> str | None:
        if isinstance(self._text, Lazy):
            self._text = self._text.make()
        return self._text

    @description.setter
    def description(self, text: str | Lazy | None) -> None:
        self._text = text

    def error(self, message: str) -> NoReturn:
        """Raise the usage error as one line (argparse would exit).

        Parameters
        ----------
        message : str
            argparse's words.

        Raises
        ------
        UsageError
            Always.
        """
        raise UsageError(f"{self.prog}: {message}")
