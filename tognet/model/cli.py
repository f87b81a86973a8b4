"""Commands: ``tognet train``, ``tognet model info|eval``, ``tognet data info|synthetic``."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from tognet.cliutil import out_file, out_folder, user_errors

model_app = typer.Typer(help="Inspect and evaluate trained TOG-Net checkpoints.", no_args_is_help=True)
data_app = typer.Typer(help="Inspect and make episode datasets.", no_args_is_help=True)


@user_errors
def train_cmd(
    data: list[Path] = typer.Option(..., "--data", help="Episode dataset folder (repeat for several)."),
    task: str = typer.Option(..., "--task", help="Task name; every dataset's manifest must name it."),
    out: Path = typer.Option(..., "--out", help="Folder for checkpoints, metrics.json and curves.png."),
    config: Path | None = typer.Option(None, "--config", help="TrainConfig JSON file (defaults otherwise)."),
    epochs: int | None = typer.Option(None, "--epochs", min=1, help="Override the config's epochs."),
    seed: int | None = typer.Option(None, "--seed", help="Override the config's seed."),
    device: str | None = typer.Option(None, "--device", help="'auto', 'cpu' or 'cuda' (overrides config)."),
    resume: bool = typer.Option(False, "--resume", help="Continue the run in --out from its last.pt."),
    init_from: Path | None = typer.Option(None, "--init-from",
                                          help="Warm start: weights and normalisation from this checkpoint."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show tqdm progress bars."),
) -> None:
    """Train a TOG-Net model for one task on episode data (validation split by object)."""
    from tognet.model.config import TrainConfig
    from tognet.model.train import train

    cfg = TrainConfig.load(config) if config else TrainConfig()
    changes = {k: v for k, v in (("epochs", epochs), ("seed", seed), ("device", device)) if v is not None}
    if changes:
        cfg = cfg.replace(**changes)
    result = train(data, task, out, cfg, resume=resume, progress=progress, log=typer.echo,
                   init_from=init_from)
    best = result.best
    typer.echo(f"done: {result.epochs_run} epochs{' (stopped early)' if result.stopped_early else ''}; "
               f"best epoch {best.get('epoch')} with {best.get('monitor')} loss {best.get('loss'):.4f}; "
               f"model {result.best_path}")


@user_errors
def info_cmd(
    checkpoint: Path = typer.Argument(..., help="A checkpoint file (best.pt or last.pt)."),
    as_json: bool = typer.Option(False, "--json", help="Print the full self-description as JSON."),
) -> None:
    """Print a checkpoint's self-description (task, config, normalisation, data, code version, metrics)."""
    from tognet.model.checkpoint import describe, load_checkpoint

    desc = describe(load_checkpoint(checkpoint))
    if as_json:
        typer.echo(json.dumps(desc, indent=2, default=str))
        return
    code = desc.get("code", {})
    split = desc.get("split", {})
    best = desc.get("best", {})
    lines = [
        f"checkpoint   {checkpoint}",
        f"format       {desc['format']} v{desc['format_version']}, created {desc.get('created')}",
        f"code         tognet {code.get('tognet')} commit {code.get('git_commit')} torch {code.get('torch')}",
        f"task         {desc.get('task')}",
        f"epoch        {desc.get('epoch')} (best {best.get('epoch')}, {best.get('monitor')} loss "
        f"{best.get('loss')}); resumable: {desc.get('resumable')}",
        f"parameters   {desc.get('parameters')}",
        f"arch         {json.dumps(desc.get('arch'))}",
        f"loss         {json.dumps(desc.get('config', {}).get('loss'))}",
        f"normalise    {json.dumps(desc.get('normalization'))}",
        f"crops        {json.dumps(desc.get('crop_config'))}",
        f"split        {json.dumps(split)}",
    ]
    for d in desc.get("data", {}).get("datasets", []):
        totals = d.get("totals") or {}
        lines.append(f"data         {d['dir']}: {len(d['shards'])} shards, {totals.get('episodes')} episodes")
    metrics = (best.get("val") or {}).get("metrics") or {}
    for head in ("grasp", "task_given_grasp", "task"):
        m = metrics.get(head)
        if m:
            lines.append(f"val {head:17s} AUC {m.get('auc')} accuracy {m.get('accuracy')} ECE {m.get('ece')}")
    if metrics.get("action"):
        lines.append(f"val action MAE {metrics['action'].get('mae')}")
    typer.echo("\n".join(lines))


@user_errors
def eval_cmd(
    checkpoint: Path = typer.Argument(..., help="A checkpoint file (best.pt or last.pt)."),
    data: list[Path] = typer.Option(..., "--data", help="Episode dataset folder (repeat for several)."),
    out: Path | None = typer.Option(None, "--out", help="Write the metrics to this JSON file too."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show tqdm progress bars."),
) -> None:
    """Loss and per-head metrics (AUC, accuracy, ECE, action error) of a checkpoint on episode data."""
    from tognet.model.train import evaluate_checkpoint

    if out is not None:
        out_file(out)
    result = evaluate_checkpoint(checkpoint, data, progress=progress)
    text = json.dumps(result, indent=2)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text + "\n")
    typer.echo(text)


def _totals_from_shards(folder: Path) -> dict[str, object]:
    """Task and manifest-style totals of a dataset folder read from its shards' label columns."""
    from tognet.data.episodes import DatasetError, _summarise, manifest_totals, read_columns, shard_paths

    entries, tasks = [], set()
    for path in shard_paths(folder):
        cols, meta = read_columns(path, ("valid", "grasp_success", "task_success", "failure"))
        entry = _summarise(cols["valid"], cols["grasp_success"], cols["task_success"], cols["failure"])
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

    from tognet.data.episodes import (
        DatasetError,
        describe_dataset,
        expand_dataset_dirs,
        read_shard,
        shard_paths,
    )

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
        typer.echo("all shards readable")


@user_errors
def data_synth_cmd(
    out: Path = typer.Argument(..., help="Dataset folder to write (appends if it exists)."),
    task: str = typer.Option("synthetic", help="Task name recorded in the manifest."),
    episodes: int = typer.Option(2000, min=1, help="Number of episodes."),
    objects: int = typer.Option(40, min=1, help="Number of distinct bar objects."),
    seed: int = typer.Option(0, help="Random seed."),
    shard_size: int = typer.Option(1024, min=1, help="Episodes per shard."),
) -> None:
    """Write synthetic bar episodes with a known labelling rule (for smoke tests of training)."""
    from tognet.data.synthetic import write_synthetic_dataset

    out_folder(out, "OUT")
    write_synthetic_dataset(out, task=task, n=episodes, shard_size=shard_size, seed=seed, n_objects=objects)
    typer.echo(f"wrote {episodes} synthetic episodes to {out}")


def register(app: typer.Typer) -> None:
    """Add ``train``, ``model`` and ``data`` to the tognet command."""
    app.command("train")(train_cmd)
    model_app.command("info")(info_cmd)
    model_app.command("eval")(eval_cmd)
    data_app.command("info")(data_info_cmd)
    data_app.command("synthetic")(data_synth_cmd)
    app.add_typer(model_app, name="model")
    app.add_typer(data_app, name="data")
