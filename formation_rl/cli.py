"""Shared command-line behaviour of the Hydra entry points."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable


def one_line_errors(main: Callable) -> Callable:
    """Print a ``ValueError`` (bad config or input) as ``error: ...`` on stderr and exit with 2."""

    @functools.wraps(main)
    def wrapper(*args, **kwargs):
        try:
            return main(*args, **kwargs)
        except ValueError as err:
            print(f"error: {err}", file=sys.stderr)
            sys.exit(2)

    return wrapper
