"""Errors that vehloc reports to users as one clear line and a non-zero exit."""

from __future__ import annotations

from collections.abc import Sequence


class VehlocError(Exception):
    """A user-facing error: bad input, missing file, inconsistent data."""


class DataError(VehlocError):
    """A data set or table is missing, malformed or inconsistent.

    `problems` lists every problem found, each naming the file (and line) and what is wrong.
    """

    def __init__(self, summary: str, problems: Sequence[str] = ()) -> None:
        self.summary = summary
        self.problems = list(problems)
        lines = [summary] + [f"  - {p}" for p in self.problems]
        super().__init__("\n".join(lines))


def exit_on_error(prog: str):
    """Decorate a console-script main: a VehlocError becomes its message on stderr and exit code 1."""
    import functools
    import sys

    def decorate(main):
        @functools.wraps(main)
        def wrapper(*args, **kwargs):
            try:
                return main(*args, **kwargs)
            except VehlocError as exc:
                print(f"{prog}: error: {exc}", file=sys.stderr)
                raise SystemExit(1) from None

        return wrapper

    return decorate
