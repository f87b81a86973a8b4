"""The ``tognet`` command. Each area of the package adds its subcommands through ``register(app)``."""

from __future__ import annotations

import importlib
import importlib.util
import sys

import typer

app = typer.Typer(
    name="tognet",
    help="Task-oriented grasping for tool manipulation, learned from simulated self-supervision.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

# Modules that define ``register(app: typer.Typer) -> None``; each is optional while the project grows.
_COMMAND_MODULES = (
    "tognet.demo.cli",
    "tognet.objects.cli",
    "tognet.sim.cli",
    "tognet.grasping.cli",
    "tognet.model.cli",
    "tognet.data.cli",
    "tognet.collect.cli",
    "tognet.planning.cli",
    "tognet.evaluate.cli",
)


@app.callback()
def _root() -> None:
    """tognet: sample grasps on a depth image, score them with TOG-Net, and learn from simulated trials."""


def _register_all() -> None:
    for name in _COMMAND_MODULES:
        parent = name.rsplit(".", 1)[0]
        if importlib.util.find_spec(parent) is None or importlib.util.find_spec(name) is None:
            continue
        importlib.import_module(name).register(app)


_register_all()


def main() -> None:
    """Entry point of the ``tognet`` console script."""
    try:
        app()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        raise SystemExit(130) from None
