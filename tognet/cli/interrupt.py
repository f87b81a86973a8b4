"""Ctrl-C and SIGTERM: the command stops its workers, keeps what it has written whole, and says in one line
what was kept and the exact command that continues."""

from __future__ import annotations

import shlex
import signal
import sys
from collections.abc import Sequence
from types import FrameType

#: Commands whose folder resumes: by running them again (collect) or with --resume (the others).
RESUMED_BY_RERUN = ("collect",)
RESUMED_BY_FLAG = ("train", "pipeline", "evaluate")


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the process is, so the same clean-up as for Ctrl-C runs."""

    signum = int(signal.SIGTERM)


class Stopped(Exception):
    """A command stopped by Ctrl-C or SIGTERM, carried past typer (which turns a KeyboardInterrupt into a
    silent exit 130) to :func:`tognet.cli.main`, which says what was kept."""

    def __init__(self, signal_exc: KeyboardInterrupt) -> None:
        super().__init__("interrupted")
        self.signal_exc = signal_exc


def _raise_terminated(signum: int, frame: FrameType | None) -> None:
    raise Terminated()


def on_sigterm_stop() -> None:
    """Make SIGTERM stop the command as Ctrl-C does (workers stopped, files closed) instead of killing
    the process where it stands."""
    signal.signal(signal.SIGTERM, _raise_terminated)


def stacks_on_sigusr1() -> None:
    """``kill -USR1 <pid>`` prints where each thread of the command is, and the command goes on."""
    import faulthandler

    stream = sys.__stderr__
    if not hasattr(signal, "SIGUSR1") or stream is None:
        return
    try:
        faulthandler.register(signal.SIGUSR1, file=stream, all_threads=True, chain=False)
    except (OSError, ValueError, AttributeError):  # no real file descriptor (embedded, captured)
        return


def _option(args: Sequence[str], name: str) -> str | None:
    for i, arg in enumerate(args):
        if arg == name and i + 1 < len(args):
            return args[i + 1]
        if arg.startswith(name + "="):
            return arg.split("=", 1)[1]
    return None


def interrupted_line(args: Sequence[str], exc: KeyboardInterrupt) -> str:
    """The one line printed when ``tognet <args>`` is stopped by a signal."""
    name = "SIGTERM" if isinstance(exc, Terminated) else "SIGINT"
    command = args[0] if args else ""
    out = _option(args, "--out")
    if out is None or command not in RESUMED_BY_RERUN + RESUMED_BY_FLAG:
        return f"interrupted ({name})"
    again = list(args)
    if command in RESUMED_BY_FLAG and "--resume" not in again:
        again.append("--resume")
    return (f"interrupted ({name}): what {out} holds is whole and kept (an unfinished job or epoch is "
            f"redone); continue with: tognet {shlex.join(again)}")


def exit_status(exc: KeyboardInterrupt) -> int:
    """128 + the signal's number, as a shell reports a process ended by it."""
    return 128 + (Terminated.signum if isinstance(exc, Terminated) else int(signal.SIGINT))


__all__ = ["Stopped", "Terminated", "exit_status", "interrupted_line", "on_sigterm_stop"]
