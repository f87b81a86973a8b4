"""Commands: ``tognet data info|synthetic`` (inspect episode datasets, write synthetic ones)."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from tognet.cli.util import check_disk, check_memory, out_folder, user_errors

#: Disk bytes of one synthetic episode: its noisy float16 crop compresses little, so the size follows the
#: crop's pixels (64 x 64, tognet.data.format.CROP_SIZE, not imported here to keep the command line's start
#: light): 6.1 kB measured by benchmarks/space.py (2026-12-06, 1.49 B per pixel), with a 1.25x margin.
SYNTHETIC_BYTES = 1.9 * 64**2
#: Memory of one buffered episode while a shard is filled (float32 crop while made, float16 kept).
BUFFERED_BYTES = 30e3
#: The most shards one ``data synthetic`` writes: the writer rewrites the manifest after every shard.
MAX_SHARDS = 10_000

data_app = typer.Typer(help="Inspect and make episode datasets.", no_args_is_help=True)


def _totals_from_shards(folder: Path) -> dict[str, object]:
    """Task and manifest-style totals of a dataset folder read from its shards' label columns."""
    from tognet.data.episodes import read_columns, shard_paths
    from tognet.data.format import DatasetError, summarise
    from tognet.data.manifest import manifest_totals

    entries, tasks = [], set()
    for path in shard_paths(folder):
        cols, meta = read_columns(path, ("valid", "grasp_success", "task_success", "failure"))
        entry = summarise(cols["valid"], cols["grasp_success"], cols["task_success"], cols["failure"])
        entries.append({**entry, "count": entry["episodes"]})
        if meta.get("task") is not None:
            tasks.add(str(meta["task"]))
    if len(tasks) > 1:
        raise DatasetError(f"{folder}: shards of several tasks ({', '.join(sorted(tasks))}) and no manifest")
    return {"task": tasks.pop() if tasks else None, "totals": manifest_totals(entries)}


@user_errors
def data_info_cmd(
    folder: Path = typer.Argument(..., help="An episode dataset folder (with manifest.json), or a folder of "
                                  "them (e.g. one per worker)."),
    check: bool = typer.Option(False, "--check", help="Also read every shard (finds corrupt ones)."),
) -> None:
    """Print a dataset's manifest totals; with --check read every shard."""
    from tqdm import tqdm

    from tognet.data.episodes import describe_dataset, expand_dataset_dirs, read_shard, shard_paths
    from tognet.data.format import DatasetError

    folders = expand_dataset_dirs([folder])
    descs = describe_dataset(folders)["datasets"]
    for d in descs:
        if not d["shards"] and d["task"] is None:
            raise DatasetError(f"{d['dir']}: not an episode dataset (no manifest.json and no shards)")
    for d in descs:
        entry = {"dir": d["dir"], "task": d["task"], "shards": len(d["shards"]), "totals": d["totals"]}
        if d["totals"] is None:  # shards without a manifest (a writer stopped early): count them ourselves
            entry.update(_totals_from_shards(Path(d["dir"])))
            typer.secho(f"note: {d['dir']} has no manifest.json (a collection stopped before writing it?); "
                        f"task and totals read from its {len(d['shards'])} shard(s)", err=True,
                        fg=typer.colors.YELLOW)
        typer.echo(json.dumps(entry, indent=2))
    if check:
        bad = []
        paths = [p for f in folders for p in shard_paths(f)]
        for path in tqdm(paths, desc="checking shards", unit="shard"):
            try:
                read_shard(path)
            except DatasetError as exc:
                bad.append(str(exc))
        for b in bad:
            typer.echo(f"bad: {b}")
        if bad:
            raise DatasetError(f"{len(bad)} bad shard(s) in {folder}")
        typer.echo("all shards readable, each matching its manifest (sha256 and count)")


@user_errors
def data_synth_cmd(
    out: Path = typer.Argument(
        ..., help="Dataset folder to write (appends if it exists; continues a stopped run of this --seed)."),
    task: str = typer.Option("synthetic", help="Task name recorded in the manifest."),
    episodes: int = typer.Option(2000, min=1, help="Number of episodes."),
    objects: int = typer.Option(40, min=1, help="Number of distinct bar objects."),
    seed: int = typer.Option(0, min=0, help="Random seed."),
    shard_size: int = typer.Option(1024, min=1, help="Episodes per shard."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show a progress bar."),
) -> None:
    """Write synthetic bar episodes with a known labelling rule (for smoke tests of training).

    OUT gets shard-NNNNN.npz files (--shard-size episodes each) and manifest.json, as a collection writes
    them; an existing dataset of the same --task is appended to, except the episodes of this --seed and
    --objects it already holds: a run stopped part way (Ctrl-C, a full disk) continues after them. The
    episodes are made and written a few thousand at a time, so memory stays flat however many are asked
    for."""
    from tqdm import tqdm

    from tognet.data.synthetic import write_synthetic_dataset

    if not task.strip():
        raise ValueError("--task must not be empty (the task name recorded in the manifest)")
    out_folder(out, "OUT")
    shards = -(-episodes // shard_size)
    if shards > MAX_SHARDS:
        raise ValueError(f"--episodes {episodes} --shard-size {shard_size}: {shards} shards, more than "
                         f"{MAX_SHARDS} (the manifest is rewritten after each); use --shard-size "
                         f"{-(-episodes // MAX_SHARDS)} or more")
    check_disk("--episodes", episodes, SYNTHETIC_BYTES, out, "episode")
    check_memory("--shard-size", shard_size, BUFFERED_BYTES, "one shard's episodes before it is written")
    done: list[int] = []
    with tqdm(total=episodes, desc="synthetic", unit="ep", disable=not progress, leave=False) as bar:
        write_synthetic_dataset(out, task=task, n=episodes, shard_size=shard_size, seed=seed,
                                n_objects=objects, progress=bar.update, resumed=done.append)
    kept = f" (it held the first {done[0]} of them, from a run of this --seed: kept)" if done[0] else ""
    typer.echo(f"wrote {episodes - done[0]} synthetic episodes to {out}{kept}")


def register(app: typer.Typer) -> None:
    """Add ``data`` to the tognet command."""
    data_app.command("info")(data_info_cmd)
    data_app.command("synthetic")(data_synth_cmd)
    app.add_typer(data_app, name="data")
