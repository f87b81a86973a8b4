"""``tognet demo``: the end-to-end demonstration run by ``make run``.

For now it generates a few objects of each kind and writes their contact sheet; it grows with the
pipeline (collection, training, evaluation).
"""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

import typer

from tognet.cliutil import user_errors


@user_errors
def demo(
    out: Path = typer.Option(Path("runs/demo"), help="Folder for everything the demo writes."),
    count: int = typer.Option(4, min=1, help="Objects of each kind to generate."),
) -> None:
    """Generate a few objects of each kind and write their contact sheet (the pipeline grows from here)."""
    from tognet.objects import generate_set
    from tognet.objects.sheet import write_contact_sheet

    out.mkdir(parents=True, exist_ok=True)
    for kind in ("primitive", "complex", "realistic"):
        folder = out / "objects" / kind
        if kind == "realistic" and importlib.util.find_spec("tognet.objects.realistic") is None:
            typer.echo("realistic: skipped (tognet/objects/realistic.py is not there yet)")
            continue
        if (folder / "catalog.json").is_file():
            shutil.rmtree(folder)  # the demo's own set from an earlier run: regenerate it from scratch
        generate_set(kind=kind, split="test", count=count, out=folder, progress=True)
        sheet = write_contact_sheet(folder, out / f"sheet_{kind}.png")
        typer.echo(f"{kind}: {count} objects in {folder}, contact sheet {sheet}")


def register(app: typer.Typer) -> None:
    """Add ``demo`` to the tognet command."""
    app.command("demo")(demo)
