"""The ``tognet`` command, the top floor: one module per area of the package (``tognet/cli/<area>.py``), each
adding its subcommands through ``register(app)``; ``util`` holds what they share. No library package
imports this one."""

from __future__ import annotations

import importlib
import os
import sys

import typer

app = typer.Typer(
    name="tognet",
    help="Task-oriented grasping for tool manipulation, learned from simulated self-supervision.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

# Modules that define ``register(app: typer.Typer) -> None`` (each imports its library lazily, inside its
# commands, so that ``tognet --help`` stays fast).
_COMMAND_MODULES = (
    "tognet.cli.demo",
    "tognet.cli.objects",
    "tognet.cli.sim",
    "tognet.cli.grasping",
    "tognet.cli.model",
    "tognet.cli.data",
    "tognet.cli.collect",
    "tognet.cli.planning",
    "tognet.cli.evaluate",
    "tognet.cli.serve",
)


@app.callback()
def _root() -> None:
    """tognet: sample grasps on a depth image, score them with TOG-Net, and learn from simulated trials."""


def _register_all() -> None:
    for name in _COMMAND_MODULES:
        importlib.import_module(name).register(app)


_register_all()

#: click's base class of usage errors, as the click typer bundles spells it (typer exports a subclass).
_CLICK_EXCEPTION: type[Exception] = next(
    c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException"
)


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``tognet`` console script (``argv``: the arguments, default ``sys.argv[1:]``).

    A usage error (an unknown option, a missing argument, a value out of its range) is one line too,
    ``error: <what> (see: tognet <command> --help)``, exit status 2, like the commands' own errors.
    Ctrl-C or SIGTERM stops the command and prints one line: what was kept and the command that
    continues (exit status 130 / 143). SIGUSR1 prints every thread's stack to stderr and goes on (to see
    where a command that seems stuck is)."""
    from tognet.cli.interrupt import (
        Stopped,
        exit_status,
        interrupted_line,
        on_sigterm_stop,
        stacks_on_sigusr1,
    )

    on_sigterm_stop()
    stacks_on_sigusr1()
    try:
        code = app(args=argv, prog_name="tognet", standalone_mode=False)
    except _CLICK_EXCEPTION as exc:
        if type(exc).__name__ == "NoArgsIsHelpError":  # typer's rich help is already printed
            text = exc.format_message()
            if text.strip():
                print(text, file=sys.stderr)
            raise SystemExit(2) from None
        ctx = getattr(exc, "ctx", None)
        where = ctx.command_path if ctx is not None else "tognet"
        message = " ".join(exc.format_message().replace("Value error, ", "").split())
        print(f"error: {message} (see: {where} --help)", file=sys.stderr)
        raise SystemExit(exc.exit_code) from None
    except typer.Abort:
        print("aborted", file=sys.stderr)
        raise SystemExit(1) from None
    except (Stopped, KeyboardInterrupt) as exc:  # Ctrl-C, or SIGTERM (tognet.cli.interrupt)
        signal_exc = exc.signal_exc if isinstance(exc, Stopped) else exc
        print(interrupted_line(sys.argv[1:] if argv is None else argv, signal_exc), file=sys.stderr)
        raise SystemExit(exit_status(signal_exc)) from None
    except BrokenPipeError:  # `tognet ... | head`: the reader has all it wanted
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 (no flush of the closed pipe at exit)
        raise SystemExit(1) from None
    raise SystemExit(code if isinstance(code, int) else 0)
