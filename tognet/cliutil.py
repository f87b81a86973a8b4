"""Helpers shared by the subcommands: turn expected errors into one clear line and exit status 2."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import typer

from tognet.config import ConfigError
from tognet.errors import TognetError

F = TypeVar("F", bound=Callable[..., Any])

#: Exceptions whose message is written for the user; anything else is a bug and keeps its traceback.
USER_ERRORS: tuple[type[BaseException], ...] = (TognetError, ConfigError, FileNotFoundError, ValueError)


def user_errors(func: F) -> F:
    """Decorator for a command: print ``error: <message>`` and exit 2 on a user-facing error."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except USER_ERRORS as exc:
            typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
            raise typer.Exit(code=2) from None

    return wrapper  # type: ignore[return-value]
