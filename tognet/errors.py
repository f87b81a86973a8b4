"""Errors shared across tognet whose messages are meant for the user, not a traceback."""


class TognetError(Exception):
    """Base class: the CLI prints the message and exits with status 2 instead of a traceback."""
