"""``tognet demo``: the end-to-end demonstration run by ``make run``.

It generates a few objects of each kind and writes their contact sheets, then shows on the simulated
tasks that the grasp matters (scripted checks), draws grasp candidates on a simulated depth image and
animates one hammering episode; then evaluates the shipped models against the paper's baselines on unseen
objects at demo scale and writes the report.
"""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

import typer

from tognet.cli.util import check_disk, check_memory, out_folder, user_errors

#: The most scenes per scripted check ``--seeds`` takes (a few episodes each, about a second).
MAX_SEEDS = 1000


@user_errors
def demo(
    out: Path = typer.Option(Path("runs/demo"), help="Folder for everything the demo writes."),
    count: int = typer.Option(4, min=1, help="PG-Primitive and PG-Complex objects to generate."),
    realistic: int = typer.Option(
        12, min=1, help="Realistic models to generate (the first N: tools, then mugs, bottles, cans...)."
    ),
    tasks: bool = typer.Option(True, help="Also run the task part: scripted checks, candidates, animation."),
    seeds: int = typer.Option(5, min=1, max=MAX_SEEDS, help="Scenes per scripted check in the task part (at "
                              f"most {MAX_SEEDS}: each is a few simulated episodes)."),
    gif: bool = typer.Option(True, help="Animate one hammering episode (needs MuJoCo's renderer: EGL)."),
    evaluate: bool = typer.Option(
        True, help="Evaluate every method with the shipped models on every task (a few minutes) and write "
        "the report (OUT/evaluation/report.html)."
    ),
) -> None:
    """Objects of each kind with contact sheets, the tasks (does the grasp matter, candidates, a GIF), then
    the shipped models against the paper's baselines on unseen objects, with a report.

    --out gets objects/<kind>/ (the generated sets), sheet_<kind>.png (contact sheets), tasks/ (grasp
    candidates on a simulated depth image, hammering.gif) and evaluation/ (report.html, results.json). Run
    again it regenerates the objects and resumes the evaluation (settings unchanged)."""
    from tognet.cli.objects import OBJECT_BYTES, RECORD_BYTES
    from tognet.objects import generate_set
    from tognet.objects.generate import realistic_count
    from tognet.objects.sheet import write_contact_sheet

    out_folder(out)
    if realistic > realistic_count():
        raise ValueError(f"--realistic {realistic}: there are {realistic_count()} realistic models")
    check_disk("--count", 2 * count, OBJECT_BYTES, out, "object", label=f"--count {count} (x 2 kinds)")
    check_memory("--count", count, RECORD_BYTES, "the objects' records")
    out.mkdir(parents=True, exist_ok=True)
    sheets: list[Path] = []
    for kind in ("primitive", "complex", "realistic"):
        folder = out / "objects" / kind
        if kind == "realistic" and importlib.util.find_spec("tognet.objects.realistic") is None:
            typer.echo("realistic: skipped (tognet/objects/realistic.py is not there yet)")
            continue
        if (folder / "catalog.json").is_file():
            shutil.rmtree(folder)  # the demo's own set from an earlier run: regenerate it from scratch
        n = count
        if kind == "realistic":
            n = realistic
        records = generate_set(kind=kind, split="test", count=n, out=folder, progress=True)
        sheets.append(write_contact_sheet(folder, out / f"sheet_{kind}.png"))
        masses = [1000 * r.mass for r in records]
        lengths = [100 * max(r.extents[:2]) for r in records]
        names = ", ".join(
            str(r.extra.get("name"))
            if kind == "realistic"
            else f"{r.shape_rule}:{'+'.join(dict.fromkeys(r.part_types))}"
            for r in records
        )
        typer.echo(
            f"{kind}: {len(records)} objects ({names}); {min(lengths):.0f}-{max(lengths):.0f} cm long, "
            f"{min(masses):.0f}-{max(masses):.0f} g; catalog {folder / 'catalog.json'}"
        )
    typer.echo("contact sheets (each object from above and from the side, 10 cm bar):")
    for sheet in sheets:
        typer.echo(f"  {sheet}")
    if tasks:
        from tognet.demo.tasks import run_task_demo

        run_task_demo(out / "tasks", seeds=seeds, gif=gif)
    if evaluate:
        from tognet.evaluate import run_demo

        run_demo(out / "evaluation", log=typer.echo)
        typer.echo(f"report: {out / 'evaluation' / 'report.html'}")


def register(app: typer.Typer) -> None:
    """Add ``demo`` to the tognet command."""
    app.command("demo")(demo)
