"""``tognet objects ...``: generate, import, inspect and draw tool-object sets."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path

import typer

from tognet.cli.util import check_disk, check_memory, out_file, out_folder, positive, user_errors

objects_app = typer.Typer(
    name="objects",
    help="Tool objects: generate PG-Primitive / PG-Complex / realistic sets, import your own meshes, "
    "list a set's catalog and draw its contact sheet.",
    no_args_is_help=True,
)


#: Disk bytes one generated object takes, by kind: the blocks its folder's files (object.xml, visual.obj,
#: collision_*.obj; several small files, each at least one 4 kB block) and its catalog entries take, as
#: benchmarks/space.py measured them (2026-12-06: 23.3, 26.2 and 44.1 kB per object), with a 1.25x margin.
OBJECT_BYTES_BY_KIND = {"primitive": 30e3, "complex": 33e3, "realistic": 56e3}
#: One object of a training set (a mix of primitive and complex): the larger of the two.
OBJECT_BYTES = max(OBJECT_BYTES_BY_KIND["primitive"], OBJECT_BYTES_BY_KIND["complex"])
#: Memory of one object's record (catalog entry) while a set is generated or read, roughly.
RECORD_BYTES = 4e3
#: The widest gripper opening ``objects stats --opening`` takes (m): wider is a unit mistake (cm or mm).
MAX_OPENING = 0.5


class Kind(StrEnum):
    """Generated object kinds."""

    primitive = "primitive"
    complex = "complex"
    realistic = "realistic"


class Split(StrEnum):
    """Dataset splits (disjoint by construction: the split is part of every id and seed)."""

    train = "train"
    test = "test"


@objects_app.command("generate")
@user_errors
def generate(
    kind: Kind = typer.Option(
        ..., "--kind", help="primitive | complex | realistic (realistic: test split only)."
    ),
    split: Split = typer.Option(Split.train, "--split", help="train | test."),
    count: int = typer.Option(
        ..., "--count", min=1, help="How many objects (indices start .. start+count-1)."
    ),
    out: Path = typer.Option(..., "--out", help="Set folder; its catalog.json keeps objects already there."),
    start: int = typer.Option(0, "--start", min=0, help="First object index (to extend a set)."),
    workers: int = typer.Option(1, "--workers", min=1, help="Processes generating in parallel."),
    config: str | None = typer.Option(
        None,
        "--config",
        help="A generator profile (wide: flat, thin, tall and short parts, lower friction, steel) or a "
        "GeneratorConfig JSON (e.g. another set's generator_config.json) instead of the defaults.",
    ),
) -> None:
    """Generate objects (deterministic: the same kind/split/index gives the same files anywhere).

    Writes one folder per object (``<kind>-<split>-<index>/``: object.xml, visual.obj, collision_*.obj)
    and the set's catalog.json, catalog.csv and generator_config.json into --out."""
    from tognet.objects.generate import generate_set, load_generator_config, realistic_count

    if kind == Kind.realistic and split == Split.train:
        raise ValueError("--kind realistic is a test set only (the realistic models are never trained "
                         "on); pass --split test")
    out_folder(out)
    cfg = load_generator_config(config) if config is not None else None
    if kind == Kind.realistic and start + count > realistic_count():
        raise ValueError(f"--count {count} --start {start}: there are {realistic_count()} realistic models "
                         f"(use --count {max(realistic_count() - start, 0)} or less)")
    check_disk("--count", count, OBJECT_BYTES_BY_KIND[kind.value], out, f"{kind.value} object")
    check_memory("--count", count, RECORD_BYTES, "the objects' records")
    records = generate_set(
        kind.value, split.value, count, out, start=start, progress=True, workers=workers, config=cfg
    )
    rules: dict[str, int] = {}
    for r in records:
        rules[r.shape_rule] = rules.get(r.shape_rule, 0) + 1
    masses = [r.mass for r in records]
    typer.echo(
        f"{len(records)} {kind.value} objects ({split.value}) in {out}: rules {rules}, "
        f"mass {1000 * min(masses):.0f}-{1000 * max(masses):.0f} g"
    )


@objects_app.command("import")
@user_errors
def import_cmd(
    src_dir: Path = typer.Argument(
        ..., help="An OBJ/STL/PLY file, or a folder of them (not searched recursively)."),
    out: Path = typer.Option(
        ..., "--out", help="Set folder to add the objects to (existing objects are kept unless --replace)."
    ),
    scale: float = typer.Option(
        1.0, "--scale", min=0.0, help="Metres per file unit (0.001 for millimetres)."
    ),
    density: float = typer.Option(1000.0, "--density", min=0.0, help="Density (kg/m^3) for the mass."),
    friction: float = typer.Option(0.8, "--friction", min=0.0, help="Sliding friction coefficient."),
    replace: bool = typer.Option(
        False, "--replace", help="Re-import files whose object is already in --out (else they are kept)."),
) -> None:
    """Import your own meshes as objects (kind 'imported').

    Each file is repaired (vertices merged, small holes filled) and checked.

    Refused with the reason: unreadable, empty, flat, zero volume, size outside 1 cm-1.5 m, not watertight.

    The other files are convex-decomposed and written. An object already in --out is kept: a file imported
    before unchanged is skipped, a changed one is refused unless --replace.

    Writes into --out as `tognet objects generate` does: a folder per object (imported-<file stem>/:
    object.xml, visual.obj, collision_*.obj) and the set's catalog.json and catalog.csv.

    Exit code: 0 if every file was imported (or skipped unchanged), 1 if any failed, 2 on a usage error.
    """
    from tognet.objects.importer import import_meshes

    positive(scale, "--scale", "metres per file unit, e.g. 0.001 for millimetres")
    positive(density, "--density", "kg/m^3, e.g. 1000 for water, 7800 for steel")
    positive(friction, "--friction", "a sliding friction coefficient, e.g. 0.8")
    if not src_dir.exists():
        raise FileNotFoundError(f"SRC_DIR {src_dir}: mesh file or folder not found")
    out_folder(out)
    report = import_meshes(src_dir, out, scale=scale, density=density, friction=friction, progress=True,
                           replace=replace)
    for record in report.records:
        typer.echo(
            f"ok      {record.object_id}: {1000 * record.mass:.0f} g, {len(record.collision_meshes)} pieces"
        )
    for _path, message in report.kept:
        typer.echo(f"kept    {message}")
    for _path, message in report.errors:
        typer.secho(f"failed  {message}", err=True, fg=typer.colors.RED)
    total = len(report.records) + len(report.errors) + len(report.kept)
    kept = f" ({len(report.kept)} unchanged, kept)" if report.kept else ""
    typer.echo(f"imported {len(report.records)} of {total} files into {out}{kept}")
    if report.errors:
        raise typer.Exit(code=1)


@objects_app.command("sheet")
@user_errors
def sheet(
    set_dir: Path = typer.Argument(..., help="Set folder (with catalog.json)."),
    out: Path = typer.Option(Path("sheet.png"), "--out", help="PNG file to write."),
    max_objects: int = typer.Option(24, "--max", min=1, help="Draw at most this many objects (first by id)."),
) -> None:
    """Draw a contact sheet: each object from above and from the side, with id, rule and mass."""
    from tognet.objects.sheet import write_contact_sheet

    out_file(out, "--out", ".png")
    path = write_contact_sheet(set_dir, out, max_objects=max_objects)
    typer.echo(f"contact sheet: {path}")


@objects_app.command("list")
@user_errors
def list_cmd(set_dir: Path = typer.Argument(..., help="Set folder (with catalog.json).")) -> None:
    """Print the catalog of a set as a table (id, kind, rule, parts, size, mass, friction, pieces)."""
    from tognet.objects.record import load_catalog

    records = load_catalog(set_dir)
    header = (
        f"{'id':<26} {'kind':<9} {'rule':<4} {'parts':<32} {'size cm':<14}"
        f" {'mass g':>7} {'fric':>5} {'pcs':>3}"
    )
    typer.echo(header)
    typer.echo("-" * len(header))
    for r in records:
        parts = "+".join(r.part_types)[:32]
        size = "x".join(f"{100 * e:.1f}" for e in r.extents)
        typer.echo(
            f"{r.object_id:<26} {r.kind:<9} {r.shape_rule:<4} {parts:<32} {size:<14} "
            f"{1000 * r.mass:>7.0f} {r.friction:>5.2f} {len(r.collision_meshes):>3}"
        )
    typer.echo(f"{len(records)} objects in {set_dir}")


@objects_app.command("stats")
@user_errors
def stats_cmd(
    set_dir: Path = typer.Argument(..., help="Set folder (with catalog.json)."),
    opening: float = typer.Option(0.08, "--opening", min=0.01, help="Gripper opening (m) for 'graspable'."),
) -> None:
    """Summarise how tool-like a set is: length, height, narrowest part, mass, head share, resting pose."""
    from tqdm import tqdm

    from tognet.objects.record import load_catalog
    from tognet.objects.stats import object_stats, summary_lines

    if opening > MAX_OPENING:
        raise ValueError(f"--opening is in metres (0.01-{MAX_OPENING}), got {opening:g}; for 8 cm pass 0.08")
    records = load_catalog(set_dir)
    if not records:
        raise ValueError(f"{set_dir}: the catalog lists no objects")
    with tqdm(records, desc="measure", unit="obj", leave=False) as bar:  # cleared before an error line
        stats = [object_stats(r, opening) for r in bar]
    for line in summary_lines(stats, opening):
        typer.echo(line)


def register(app: typer.Typer) -> None:
    """Add the ``objects`` command group to the tognet command."""
    app.add_typer(objects_app, name="objects")
