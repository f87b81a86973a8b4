"""Commands: ``tognet train`` and ``tognet model info|eval`` (``tognet data`` is in tognet/data/cli.py)."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from tognet.cli.util import out_file, out_folder, user_errors
from tognet.io import atomic_write_text

model_app = typer.Typer(help="Inspect and evaluate trained TOG-Net checkpoints.", no_args_is_help=True)


@user_errors
def train_cmd(
    data: list[Path] = typer.Option(..., "--data", help="Episode dataset folder (repeat for several)."),
    task: str = typer.Option(..., "--task", help="Task name; every dataset's manifest must name it."),
    out: Path = typer.Option(..., "--out", help="Folder for checkpoints, metrics.json and curves.png."),
    config: Path | None = typer.Option(None, "--config", help="TrainConfig JSON file (defaults otherwise)."),
    epochs: int | None = typer.Option(None, "--epochs", min=1, help="Override the config's epochs."),
    seed: int | None = typer.Option(None, "--seed", min=0, help="Override the config's seed."),
    device: str | None = typer.Option(None, "--device", help="'auto', 'cpu' or 'cuda' (overrides config)."),
    resume: bool = typer.Option(False, "--resume", help="Continue the run in --out from its last.pt."),
    init_from: Path | None = typer.Option(None, "--init-from",
                                          help="Warm start: weights and normalisation from this checkpoint."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show tqdm progress bars."),
) -> None:
    """Train a TOG-Net model for one task on episode data (validation split by object).

    Writes into --out: last.pt (after every epoch, resumable), best.pt (the best validation epoch, what
    planners load), metrics.json (per-epoch losses and metrics), curves.png, config.json (the TrainConfig)
    and data.json (the shards trained on). --resume continues the run
    in --out from its last.pt (refused when there is none); without it an --out that already holds a run is
    refused."""
    from tognet.model.config import TrainConfig
    from tognet.model.train import train

    out_folder(out)
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


#: How ``model info`` words the way a checkpoint's bytes were checked on reading.
VERIFIED = {
    "digest": "content matches the digest written into it",
    "shipped": "a shipped model: its bytes match the sha256 of its tognet/models/*.json",
    "none": "not checked: written before checkpoints carried a digest (retrain or re-export to add one)",
}


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
        f"verified     {VERIFIED.get(desc.get('verified'), desc.get('verified'))}",
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
        atomic_write_text(out, text + "\n")
    typer.echo(text)


def register(app: typer.Typer) -> None:
    """Add ``train`` and ``model`` to the tognet command."""
    app.command("train")(train_cmd)
    model_app.command("info")(info_cmd)
    model_app.command("eval")(eval_cmd)
    app.add_typer(model_app, name="model")
