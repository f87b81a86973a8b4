"""Training of one TOG-Net model over episode data (validation split by object, early stopping, resume,
warm start from an earlier checkpoint).

The data is streamed (:class:`tognet.data.stream.EpisodeStream`): a listing pass reads only the shards'
object ids and validity flags (the split by object and the counts), then every epoch reads the shards in
a seeded random order through a shuffle buffer of ``TrainConfig.shuffle_buffer`` episodes, and every
validation pass reads the validation episodes in a fixed order. Memory stays flat whatever the dataset
size; normalisation statistics come from at most ~4096 training episodes of a few (seeded) shards.

Writes into ``out``::

    config.json     the TrainConfig used
    data.json       description of the dataset folders (shards, counts, sha256), the split and the
                    checkpoint the weights were initialised from (``init_from``; None for a fresh init)
    last.pt         checkpoint after the latest epoch, with optimiser and RNG state (resumable)
    best.pt         checkpoint of the epoch with the best validation loss (what planners load)
    metrics.json    per-epoch history (train/validation loss components, per-head metrics) and the best
    curves.png      training curves
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from tognet.data.episodes import dataset_configs, describe_dataset
from tognet.data.stream import Batch, EpisodeStream
from tognet.errors import TognetError
from tognet.io import atomic_path, atomic_write_text, sha256_file
from tognet.model.checkpoint import (
    CheckpointError,
    load_checkpoint,
    model_from_checkpoint,
    save_checkpoint,
)
from tognet.model.config import TrainConfig
from tognet.model.loss import (
    masked_sums,
    progress_sum,
    reduce_sums,
    resolve_loss,
    scene_rank_sum,
    tognet_loss,
)
from tognet.model.metrics import head_metrics
from tognet.model.network import TOGNet, normalization_from_data
from tognet.model.runtime import select_device, set_threads, tune_allocator

#: Config fields that may differ when resuming (everything else must match the checkpoint).
RESUMABLE_CHANGES = ("epochs", "patience", "device", "num_threads", "eval_batch_size")
#: Most training episodes read for the normalisation statistics (crop, z and action mean/std).
NORMALIZATION_SAMPLE = 4096


class TrainingError(TognetError):
    """Training cannot start or continue (no data, bad resume, ...)."""


@dataclasses.dataclass
class TrainResult:
    """Where training wrote its files and how it ended."""

    out: Path
    best_path: Path
    last_path: Path
    epochs_run: int
    best: dict[str, Any]
    stopped_early: bool
    history: list[dict[str, Any]]


def seed_everything(seed: int, deterministic: bool, num_threads: int) -> None:
    """Seed torch and numpy's global state, fix threads and (optionally) deterministic algorithms."""
    set_threads(num_threads)
    torch.manual_seed(seed)
    np.random.seed(seed % (2**32))
    if deterministic:
        os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
        torch.use_deterministic_algorithms(True, warn_only=True)
        torch.backends.cudnn.benchmark = False
        torch.backends.cudnn.deterministic = True


def _as_jsonable(x: Any) -> Any:
    if isinstance(x, torch.Tensor):
        return x.item() if x.numel() == 1 else x.tolist()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


@torch.no_grad()
def evaluate(model: TOGNet, batches: Iterable[Batch], config: TrainConfig, progress: bool = False,
             total: int | None = None) -> dict[str, Any]:
    """Validation loss (components, reduced over all the batches together as in training) and per-head
    metrics, over ``batches`` (e.g. :meth:`EpisodeStream.batches`; ``total``: their number, for the bar).
    Only predictions and labels are kept, not crops. An action-conditioned model is scored at each
    episode's own action (its Q_T|G,a), as it is trained."""
    model.eval()
    device = next(model.parameters()).device
    loss_config = resolve_loss(config.loss, model.action_std)
    n = 0
    sums = torch.zeros(5, dtype=torch.float64)
    counts = torch.zeros(4, dtype=torch.float64)
    q_g, q_tg, act, s_g, s_t, a_true, scene = [], [], [], [], [], [], []
    for batch in tqdm(batches, total=total, desc="evaluating", unit="batch", disable=not progress,
                      leave=False, mininterval=1.0):
        batch = batch.steady_grasps(config.loss.max_lift_tilt)
        b = batch.to(device)
        out = _forward(model, b)
        a_pred = model.denormalize_action(out["action_norm"])
        terms = masked_sums(out["q_g_logit"], out["q_tg_logit"], a_pred, b.s_g, b.s_t, b.action,
                            loss_config.action_sigma)
        sums[:3] += torch.stack(terms[:3]).double().cpu()
        counts[:2] += torch.stack(terms[3:]).double().cpu()
        if "progress_logit" in out:
            s_p, n_p = progress_sum(out["progress_logit"], b.progress, b.s_g)
            sums[3] += float(s_p)
            counts[2] += float(n_p)
        if b.scene is not None:
            s_r, n_r = scene_rank_sum(out["q_g_logit"], out["q_tg_logit"], b.s_t, b.scene)
            sums[4] += float(s_r)
            counts[3] += float(n_r)
            scene.append(batch.scene.cpu())
        q_g.append(torch.sigmoid(out["q_g_logit"]).cpu())
        q_tg.append(_probability(out["q_tg_logit"]).cpu())
        act.append(a_pred.cpu())
        s_g.append(batch.s_g.cpu())
        s_t.append(batch.s_t.cpu())
        a_true.append(batch.action.cpu())
        n += len(batch)
    result: dict[str, Any] = {"count": n}
    if n == 0:
        return result
    g, t, a = reduce_sums(sums[0], sums[1], sums[2], n, counts[0], counts[1], loss_config)
    p = loss_config.weight_progress * sums[3] / (n if loss_config.reduction == "batch"
                                                 else max(float(counts[2]), 1.0))
    r = loss_config.weight_rank * sums[4] / max(float(counts[3]), 1.0)
    result.update(loss=float(g + t + a + p + r), grasp=float(g), task=float(t), action=float(a),
                  progress=float(p), rank=float(r), classification=float(g + t))
    result["metrics"] = head_metrics(
        torch.cat(q_g).numpy(), torch.cat(q_tg).numpy(), torch.cat(act).numpy(),
        torch.cat(s_g).numpy(), torch.cat(s_t).numpy(), torch.cat(a_true).numpy(),
        torch.cat(scene).numpy() if len(scene) == len(s_t) else None,
    )
    return result


def _probability(logit: torch.Tensor) -> torch.Tensor:
    """Sigmoid of logits (N,), or the members' mean probability of logits (N, members)."""
    p = torch.sigmoid(logit)
    return p.mean(dim=1) if p.dim() == 2 else p


def _forward(model: TOGNet, b: Batch) -> dict[str, torch.Tensor]:
    """The model on a batch; an action-conditioned one sees each episode's own action."""
    return model(b.crop, b.z, b.action) if model.action_conditioned else model(b.crop, b.z)


def crop_config_from_data(data_dirs: Sequence[str | Path], arch: Any) -> dict[str, Any] | None:
    """The CropConfig (as a dict) the datasets' crops were made with, from the configs saved beside the
    data; None when no dataset saved one. Datasets with different crop configs, or crops that do not fit
    the architecture's crop sizes, raise TrainingError."""
    from tognet.config import ConfigError
    from tognet.grasping.crops import CropConfig

    found: dict[str, tuple[Path, CropConfig]] = {}
    for path, fields in dataset_configs(data_dirs, "CropConfig"):
        try:
            cfg = CropConfig.from_dict(fields, where=str(path))
        except ConfigError as exc:
            raise TrainingError(f"{path}: not a valid CropConfig ({exc})") from exc
        found.setdefault(json.dumps(cfg.to_dict(), sort_keys=True), (path, cfg))
    if not found:
        return None
    if len(found) > 1:
        paths = [str(p) for p, _ in found.values()]
        raise TrainingError(f"the datasets' crops were made with different crop configs ({paths}); train on "
                            "data made with one crop config")
    path, cfg = next(iter(found.values()))
    if (cfg.size, cfg.center_size) != (arch.crop_size, arch.center_size):
        raise TrainingError(f"{path}: crops of {cfg.size} px (centre {cfg.center_size}) but the architecture "
                            f"takes {arch.crop_size} (centre {arch.center_size})")
    return cfg.to_dict()


def _config_differences(a: TrainConfig, b: TrainConfig) -> list[str]:
    da, db = a.to_dict(), b.to_dict()
    return [k for k in da if da[k] != db.get(k) and k not in RESUMABLE_CHANGES]


def _data_fingerprint(desc: dict[str, Any]) -> list[tuple[str, list[Any]]]:
    # the shards' names, counts and hashes, not the folder paths (a relative --data may differ on resume)
    return [(d["task"], [(s["file"], s["count"], s["sha256"]) for s in d["shards"]])
            for d in desc["datasets"]]


def plot_curves(history: Sequence[dict[str, Any]], path: Path) -> Path:
    """Training and validation loss components, and validation AUCs, per epoch (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    epochs = [h["epoch"] for h in history]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for key, style in (("loss", "-"), ("grasp", "--"), ("task", "-."), ("action", ":")):
        axes[0].plot(epochs, [h["train"][key] for h in history], style, label=f"train {key}")
        if all(h["val"].get(key) is not None for h in history):
            axes[1].plot(epochs, [h["val"][key] for h in history], style, label=f"val {key}")
    axes[0].set_title("training loss")
    axes[1].set_title("validation loss")
    for head in ("grasp", "task_given_grasp", "task"):
        vals = [h["val"].get("metrics", {}).get(head, {}).get("auc") for h in history]
        axes[2].plot(epochs, [np.nan if v is None else v for v in vals], marker="o", label=f"{head} AUC")
    axes[2].set_title("validation ROC-AUC")
    axes[2].set_ylim(0.4, 1.0)
    for ax in axes:
        ax.set_xlabel("epoch")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90)
    plt.close(fig)
    return path


def _distinct_dirs(data_dirs: Sequence[str | Path]) -> None:
    """TrainingError when one dataset folder is given twice (its episodes would count double)."""
    seen: dict[Path, str | Path] = {}
    for d in data_dirs:
        key = Path(d).resolve()
        if key in seen:
            raise TrainingError(f"--data {d} is the same folder as --data {seen[key]}: its episodes would be "
                                "trained on twice; give each dataset folder once")
        seen[key] = d


def train(
    data_dirs: Sequence[str | Path],
    task: str,
    out: str | Path,
    config: TrainConfig | None = None,
    *,
    resume: bool = False,
    init_from: str | Path | None = None,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> TrainResult:
    """Train (or resume training) a TOG-Net model on the episodes in ``data_dirs`` for ``task``.

    ``init_from``: a checkpoint (e.g. the previous round's ``best.pt``) whose weights and normalisation
    start the run instead of a fresh initialisation; it must be of the same task and architecture
    (TrainingError otherwise) and is recorded in ``data.json``, ``metrics.json`` and the checkpoints'
    ``data``. When resuming (``resume`` with a ``last.pt`` in ``out``) the run continues from ``last.pt``
    and ``init_from`` is ignored.

    torch's thread count and deterministic-algorithms setting are changed while training and restored
    afterwards."""
    _distinct_dirs(data_dirs)
    saved = (torch.get_num_threads(), torch.are_deterministic_algorithms_enabled(),
             torch.is_deterministic_algorithms_warn_only_enabled())
    try:
        return _train(data_dirs, task, out, config, resume=resume, init_from=init_from, progress=progress,
                      log=log)
    finally:
        torch.set_num_threads(saved[0])
        torch.use_deterministic_algorithms(saved[1], warn_only=saved[2])


def _load_init(
    init_from: str | Path, task: str, config: TrainConfig
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The checkpoint to warm-start from (checked: same task, same architecture) and its record for
    data.json (path, sha256, epoch, task, best)."""
    path = Path(init_from)
    payload = load_checkpoint(path, map_location="cpu")
    if payload["task"] != task:
        raise TrainingError(f"{path}: a checkpoint of task {payload['task']!r}, but training task {task!r}; "
                            "initialise only from a checkpoint of the same task")
    arch: Any = payload["config_obj"].arch
    if arch != config.arch:
        mine, theirs = config.arch.to_dict(), arch.to_dict()
        diff = sorted(k for k in mine if mine[k] != theirs.get(k))
        raise TrainingError(f"{path}: its architecture differs from the config's in {diff}; initialise from "
                            "a checkpoint of the same architecture (or train from scratch)")
    info = {"path": str(path.resolve()), "sha256": sha256_file(path), "task": payload["task"],
            "epoch": int(payload["epoch"]), "best": {k: payload["best"].get(k) for k in ("epoch", "loss")},
            "crop_config": payload.get("crop_config")}
    return payload, info


def _normalization(stream: EpisodeStream) -> dict[str, object]:
    """:func:`normalization_from_data` of at most NORMALIZATION_SAMPLE training episodes (a few seeded
    shards), the crops' mean and std accumulated in float64 over chunks (not one float64 copy of them
    all: 128 MiB for 4096 crops)."""
    sample = stream.sample("train", NORMALIZATION_SAMPLE)
    crops = sample["crop"]
    stats = normalization_from_data(
        torch.from_numpy(crops[:2]), torch.from_numpy(sample["z"]), torch.from_numpy(sample["action"]),
        torch.from_numpy(sample["task_success"].astype(np.float32)),
    )
    chunks = range(0, len(crops), 256)
    n = crops.size
    mean = sum(float(crops[i : i + 256].sum(dtype=np.float64)) for i in chunks) / n
    sq = sum(float(np.square(crops[i : i + 256].astype(np.float64) - mean).sum()) for i in chunks)
    stats["crop_mean"] = mean
    stats["crop_std"] = max(math.sqrt(sq / max(n - 1, 1)), 1e-6)  # unbiased, floored as in the function
    return stats


def _check_request(out: Path, config: TrainConfig, resume: bool) -> None:
    """Refuse a run that cannot start: --out taken (or not a folder), nothing to resume, bad batch sizes."""
    last_path, best_path = out / "last.pt", out / "best.pt"
    if out.exists() and not out.is_dir():
        raise TrainingError(f"{out}: exists and is not a folder; pass another --out")
    if not resume and (last_path.exists() or best_path.exists()):
        found = "last.pt" if last_path.exists() else "best.pt"
        raise TrainingError(f"{out}: already holds a training run ({found}); pass --resume or another --out")
    if resume and not last_path.exists() and not (out / "config.json").exists():
        raise TrainingError(f"{last_path}: nothing to resume (no last.pt in {out})")
    if config.batch_size < 2:
        raise TrainingError("batch_size must be >= 2 (batch norm needs two samples)")
    if config.shuffle_buffer < 0:
        raise TrainingError(f"shuffle_buffer must be >= 0, got {config.shuffle_buffer}")


@dataclasses.dataclass
class _Data:
    """The episodes a run trains on: the stream, its description for data.json, the crops' config and the
    split by object."""

    stream: EpisodeStream
    counts: dict[str, Any]
    desc: dict[str, Any]
    crop_config: dict[str, Any] | None
    split: dict[str, Any]


def _open_data(data_dirs: Sequence[str | Path], task: str, config: TrainConfig,
               init: tuple[dict[str, Any], dict[str, Any]] | None, init_from: str | Path | None,
               progress: bool, log: Callable[[str], None]) -> _Data:
    """List the datasets (split by object, counts), check there is enough to train on and that a warm
    start's crops match the data's."""
    stream = EpisodeStream(data_dirs, task, val_fraction=config.val_fraction, seed=config.seed,
                           shuffle_buffer=config.shuffle_buffer, skip_bad=config.skip_bad_shards,
                           progress=progress, scene_batches=config.loss.weight_rank > 0)
    counts = stream.counts()
    if counts["valid"] < 2:
        raise TrainingError(f"only {counts['valid']} valid episodes in {list(map(str, data_dirs))}")
    desc = describe_dataset(data_dirs)
    crop_config = crop_config_from_data(data_dirs, config.arch)
    if crop_config is None:
        log("note: the datasets saved no CropConfig; the checkpoint cannot tell planners the crops' metric "
            "extent (they will assume the default CropConfig)")
    if init is not None and crop_config is not None and init[1]["crop_config"] not in (None, crop_config):
        diff = sorted(k for k in crop_config if crop_config[k] != init[1]["crop_config"].get(k))
        raise TrainingError(f"{init_from}: trained on crops made with another CropConfig than the data's "
                            f"(differs in {diff}); initialise from a checkpoint trained on such crops")
    split = {
        "train_episodes": counts["train_episodes"], "val_episodes": counts["val_episodes"],
        "train_objects": counts["train_objects"], "val_objects": counts["val_objects"],
        "val_fraction": config.val_fraction, "seed": config.seed,
    }
    if split["train_episodes"] < 2:
        raise TrainingError(f"only {split['train_episodes']} training episodes after the split by object")
    if split["val_episodes"] == 0:
        warnings.warn("no validation objects (one object, or val_fraction=0): early stopping uses the "
                      "training loss", stacklevel=3)
    return _Data(stream, counts, desc, crop_config, split)


@dataclasses.dataclass
class _State:
    """What an epoch changes and a resume restores."""

    model: TOGNet
    optimizer: torch.optim.Optimizer
    scheduler: torch.optim.lr_scheduler.LRScheduler
    history: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    best: dict[str, Any] = dataclasses.field(default_factory=lambda: {"loss": None, "epoch": 0})
    bad_epochs: int = 0
    start_epoch: int = 0


def _optimise(model: TOGNet, config: TrainConfig) -> tuple[torch.optim.Optimizer, Any]:
    optimizer = torch.optim.Adam(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    return optimizer, torch.optim.lr_scheduler.ExponentialLR(optimizer, gamma=config.lr_decay)


def _start_state(data: _Data, task: str, out: Path, config: TrainConfig, device: torch.device,
                 payload: dict[str, Any] | None, init: tuple[dict[str, Any], dict[str, Any]] | None,
                 init_from: str | Path | None, log: Callable[[str], None]) -> _State:
    """The model and optimiser to train: resumed from ``payload`` (last.pt, checked against this run),
    warm-started from ``init`` or fresh (normalised on the data). Sets ``data.desc["init_from"]``."""
    model = TOGNet(config.arch).to(device)  # made first in every case: the torch RNG then runs the same
    if payload is not None:
        last_path = out / "last.pt"
        old: TrainConfig = payload["config_obj"]
        diff = _config_differences(old, config)
        if diff:
            raise CheckpointError(f"{last_path}: config differs from the checkpoint's in {diff}; only "
                                  f"{list(RESUMABLE_CHANGES)} may change on --resume")
        if payload["task"] != task:
            raise CheckpointError(f"{last_path}: trained for task {payload['task']!r}, not {task!r}")
        if _data_fingerprint(payload["data"]) != _data_fingerprint(data.desc):
            raise CheckpointError(f"{last_path}: the dataset changed since this run started (shards or "
                                  "counts differ); start a new run in another --out")
        tr = payload.get("training")
        if tr is None:
            raise CheckpointError(f"{last_path}: holds no training state; cannot resume")
        data.desc["init_from"] = payload["data"].get("init_from")
        model = model_from_checkpoint(payload, last_path).to(device)
        optimizer, scheduler = _optimise(model, config)
        optimizer.load_state_dict(tr["optimizer"])
        scheduler.load_state_dict(tr["scheduler"])
        torch.set_rng_state(tr["rng_torch"].cpu())
        state = _State(model, optimizer, scheduler, list(tr["history"]), dict(payload["best"]),
                       int(tr["bad_epochs"]), int(payload["epoch"]))
        log(f"resuming {out} after epoch {state.start_epoch} (best val loss {state.best.get('loss')})")
        return state
    if init is not None:
        init_payload, data.desc["init_from"] = init
        model = model_from_checkpoint(init_payload, init_from).to(device)  # weights and normalisation
        log(f"initialised from {init_from} (epoch {init_payload['epoch']}, task {task}): its weights and "
            "normalisation")
    else:
        data.desc["init_from"] = None
        model.set_normalization(_normalization(data.stream))
    out.mkdir(parents=True, exist_ok=True)
    return _State(model, *_optimise(model, config))


def _train_epoch(state: _State, data: _Data, config: TrainConfig, loss_config: Any, epoch: int,
                 device: torch.device, progress: bool) -> dict[str, Any]:
    """One pass over the training episodes; the mean loss terms and the speed."""
    model, optimizer = state.model, state.optimizer
    model.train()
    sums = {k: 0.0 for k in ("loss", "grasp", "task", "action", "progress", "rank")}
    used = 0
    t0 = time.perf_counter()
    bar = tqdm(data.stream.batches("train", config.batch_size, epoch=epoch),
               total=data.stream.num_batches("train", config.batch_size),
               desc=f"epoch {epoch + 1}/{config.epochs}", unit="batch", disable=not progress, leave=False,
               mininterval=1.0)
    for batch in bar:
        if len(batch) < 2:
            continue  # batch norm cannot train on a single sample (only the epoch's last batch can be)
        b = batch.steady_grasps(config.loss.max_lift_tilt).to(device)
        out_b = _forward(model, b)
        parts = tognet_loss(out_b["q_g_logit"], out_b["q_tg_logit"],
                            model.denormalize_action(out_b["action_norm"]), b.s_g, b.s_t, b.action,
                            loss_config, out_b.get("progress_logit"), b.progress, b.scene)
        optimizer.zero_grad(set_to_none=True)
        parts["loss"].backward()
        optimizer.step()
        for k in sums:
            sums[k] += float(parts[k].detach()) * len(b)
        used += len(b)
        bar.set_postfix(loss=f"{float(parts['loss'].detach()):.4f}", refresh=False)
    seconds = time.perf_counter() - t0
    stats: dict[str, Any] = {k: v / max(used, 1) for k, v in sums.items()}
    stats["samples_per_s"] = used / seconds if seconds > 0 else None
    stats["seconds"] = seconds
    return stats


def _monitored(config: TrainConfig, train_stats: dict[str, Any], val_stats: dict[str, Any]) -> float:
    """The number early stopping and the best checkpoint go by (validation's when there is one)."""
    if config.monitor == "classification":
        return val_stats.get("classification", train_stats["grasp"] + train_stats["task"])
    return val_stats.get("loss", train_stats["loss"])


def _train(
    data_dirs: Sequence[str | Path],
    task: str,
    out: str | Path,
    config: TrainConfig | None,
    *,
    resume: bool,
    init_from: str | Path | None,
    progress: bool,
    log: Callable[[str], None],
) -> TrainResult:
    """Train one task's model into ``out`` (see :func:`train`)."""
    config = config or TrainConfig()
    out = Path(out)
    last_path, best_path = out / "last.pt", out / "best.pt"
    _check_request(out, config, resume)
    # read the run to resume (or the checkpoint to start from) before the data, so a bad file fails at once
    payload, init = _resume_or_init(out, last_path, resume, init_from, task, config, log)

    seed_everything(config.seed, config.deterministic, config.num_threads)
    tune_allocator()
    device = select_device(config.device)
    data = _open_data(data_dirs, task, config, init, init_from, progress, log)
    split = data.split
    state = _start_state(data, task, out, config, device, payload, init, init_from, log)
    init_info = data.desc["init_from"]

    _write_run_files(out, config, data, task, device, log)
    _repair_best(out, state, data, config, task, payload, log)
    loss_config = _loss_config(config, state, log)
    stopped_early = False
    for epoch in range(state.start_epoch, config.epochs):
        if state.bad_epochs >= config.patience:
            stopped_early = True
            break
        train_stats = _train_epoch(state, data, config, loss_config, epoch, device, progress)
        seconds = train_stats.pop("seconds")
        lr = state.optimizer.param_groups[0]["lr"]
        state.scheduler.step()
        val_stats = (evaluate(state.model, data.stream.batches("val", config.eval_batch_size), config)
                     if split["val_episodes"] else {"count": 0})
        monitor = _monitored(config, train_stats, val_stats)
        record = {"epoch": epoch + 1, "lr": lr, "seconds": seconds, "train": train_stats, "val": val_stats}
        state.history.append(record)
        if not math.isfinite(monitor):
            raise TrainingError(f"loss is {monitor} at epoch {epoch + 1}; lower the learning rate or check "
                                "the data (last good state: last.pt)")
        improved = _end_epoch(state, monitor, val_stats, epoch, config, split)
        _save_epoch(out, state, data, config, task, epoch, record, improved)
        _write_metrics(out, state.history, state.best, split, task, init_info)
        _log_epoch(log, epoch, train_stats, val_stats, improved)
        if state.bad_epochs >= config.patience and epoch + 1 < config.epochs:
            stopped_early = True
            log(f"early stop: no better {state.best['monitor']} loss for {state.bad_epochs} epochs "
                f"(best epoch {state.best['epoch']})")
            break
    if state.history:
        plot_curves(state.history, out / "curves.png")
    _write_metrics(out, state.history, state.best, split, task, init_info, stopped_early=stopped_early)
    if not best_path.exists():
        raise TrainingError(f"{out}: no epoch was trained (epochs={config.epochs})")
    return TrainResult(out=out, best_path=best_path, last_path=last_path, epochs_run=len(state.history),
                       best=state.best, stopped_early=stopped_early, history=state.history)


def _resume_or_init(
    out: Path, last_path: Path, resume: bool, init_from: str | Path | None, task: str, config: TrainConfig,
    log: Callable[[str], None],
) -> tuple[dict[str, Any] | None, tuple[dict[str, Any], dict[str, Any]] | None]:
    """The last.pt payload to resume from (``resume``), else the checkpoint to warm-start from, if any."""
    payload = load_checkpoint(last_path, map_location="cpu") if resume and last_path.exists() else None
    if resume and payload is None:  # started (config.json) but stopped before its first epoch was saved
        log(f"note: {out} holds no saved epoch (stopped during the first, e.g. by a full disk); starting it "
            "again from epoch 1")
    init: tuple[dict[str, Any], dict[str, Any]] | None = None
    if init_from is not None:
        if payload is not None:
            log(f"note: resuming {out} from its last.pt; init_from={init_from} is ignored")
        else:
            init = _load_init(init_from, task, config)
    return payload, init


def _write_run_files(out: Path, config: TrainConfig, data: _Data, task: str, device: torch.device,
                     log: Callable[[str], None]) -> None:
    """Write config.json and data.json into ``out`` and log the split."""
    split = data.split
    config.save(out / "config.json")
    atomic_write_text(out / "data.json", json.dumps({**data.desc, "split": split}, indent=2) + "\n",
                      fsync=False)
    log(f"task {task}: {split['train_episodes']} training episodes ({split['train_objects']} objects), "
        f"{split['val_episodes']} validation ({split['val_objects']} objects) in {data.counts['shards']} "
        f"shards, device {device}")


def _loss_config(config: TrainConfig, state: _State, log: Callable[[str], None]) -> Any:
    """The loss settings the run trains on (see :func:`resolve_loss`); logs a data-derived Sigma."""
    loss_config = resolve_loss(config.loss, state.model.action_std)
    if config.loss.action_sigma_source == "data":
        log("action term's Sigma^(1/2) from the data's successful actions: "
            + ", ".join(f"{v:.3g}" for v in loss_config.action_sigma))
    return loss_config


def _save_epoch(out: Path, state: _State, data: _Data, config: TrainConfig, task: str, epoch: int,
                record: dict[str, Any], improved: bool) -> None:
    """Write last.pt (with the training state to resume) and then, when the epoch improved, best.pt: a
    stop between the two (a full disk) leaves a last.pt whose best epoch is itself, from which
    :func:`_repair_best` writes best.pt on resume."""
    common = _common(state, data, config, task, epoch + 1, record)
    save_checkpoint(out / "last.pt", **common, training={
        "optimizer": state.optimizer.state_dict(), "scheduler": state.scheduler.state_dict(),
        "rng_torch": torch.get_rng_state(), "history": state.history, "bad_epochs": state.bad_epochs,
    })
    if improved:
        save_checkpoint(out / "best.pt", **common)


def _common(state: _State, data: _Data, config: TrainConfig, task: str, epoch: int, record: dict[str, Any]
            ) -> dict[str, Any]:
    """What best.pt and last.pt both hold."""
    return {"model": state.model, "config": config, "task": task, "data": data.desc, "split": data.split,
            "epoch": epoch, "best": state.best, "metrics": record, "crop_config": data.crop_config}


def _repair_best(out: Path, state: _State, data: _Data, config: TrainConfig, task: str,
                 payload: dict[str, Any] | None, log: Callable[[str], None]) -> None:
    """On resume: when last.pt's epoch was the best one and best.pt does not hold it (the run stopped
    between the two writes), write best.pt from it (the same weights)."""
    if payload is None or state.best.get("epoch") != payload.get("epoch"):
        return
    best_path = out / "best.pt"
    if best_path.exists():
        try:
            if load_checkpoint(best_path, map_location="cpu").get("epoch") == payload["epoch"]:
                return
        except Exception:  # noqa: BLE001 - a damaged best.pt is written again below
            pass
    save_checkpoint(best_path, **_common(state, data, config, task, int(payload["epoch"]),
                                         payload.get("metrics") or {}))
    log(f"note: best.pt written again from last.pt (epoch {payload['epoch']}, the best so far)")


def _end_epoch(state: _State, monitor: float, val_stats: dict[str, Any], epoch: int, config: TrainConfig,
               split: dict[str, Any]) -> bool:
    """Keep the best epoch and count the epochs without improvement; whether this one improved."""
    improved = state.best["loss"] is None or monitor < state.best["loss"] - config.min_delta
    if improved:
        kind = " classification" if config.monitor == "classification" else ""
        state.best = {"loss": float(monitor), "epoch": epoch + 1,
                      "monitor": ("val" if split["val_episodes"] else "train") + kind, "val": val_stats}
        state.bad_epochs = 0
    else:
        state.bad_epochs += 1
    return improved


def _log_epoch(log: Callable[[str], None], epoch: int, train_stats: dict[str, Any], val_stats: dict[str, Any],
               improved: bool) -> None:
    m = val_stats.get("metrics", {})
    log(f"epoch {epoch + 1}: train loss {train_stats['loss']:.4f}, val loss "
        f"{val_stats.get('loss', float('nan')):.4f}, Q_G AUC {_fmt(m.get('grasp', {}).get('auc'))}, "
        f"Q_T|G AUC {_fmt(m.get('task_given_grasp', {}).get('auc'))}, "
        f"within-scene AUC {_fmt(m.get('task', {}).get('scene_auc'))}"
        f"{' *' if improved else ''} ({train_stats['samples_per_s']:.0f} samples/s)")


def _fmt(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.3f}"


def _write_metrics(out: Path, history: list[dict[str, Any]], best: dict[str, Any], split: dict[str, Any],
                   task: str, init_from: dict[str, Any] | None, stopped_early: bool | None = None) -> None:
    payload = {"task": task, "split": split, "init_from": init_from, "best": best, "history": history}
    if stopped_early is not None:
        payload["stopped_early"] = stopped_early
    text = json.dumps(payload, indent=2, default=_as_jsonable, allow_nan=False) + "\n"
    atomic_write_text(out / "metrics.json", text, fsync=False)


def evaluate_checkpoint(path: str | Path, data_dirs: Sequence[str | Path], *, skip_bad: bool = False,
                        device: str | None = "cpu", progress: bool = False) -> dict[str, Any]:
    """Loss components and per-head metrics of a checkpoint on every valid episode of ``data_dirs``
    (e.g. episodes on held-out test objects), streamed shard by shard. The data must be of the
    checkpoint's task, and made with the checkpoint's CropConfig when both record one.

    The result holds ``count``, the loss components ``loss``, ``grasp``, ``task`` (the Q_T|G term) and
    ``action``, ``metrics`` per head, ``objects``, ``task_name`` (the checkpoint's task) and
    ``checkpoint``."""
    payload = load_checkpoint(path)
    config: TrainConfig = payload["config_obj"]
    dev = select_device(device)
    model = model_from_checkpoint(payload, path).to(dev)
    data_crop = crop_config_from_data(data_dirs, config.arch)
    trained_crop = payload.get("crop_config")
    if data_crop is not None and trained_crop is not None and data_crop != trained_crop:
        diff = sorted(k for k in data_crop if data_crop[k] != trained_crop.get(k))
        raise CheckpointError(f"{path}: trained on crops made with another CropConfig than the data's "
                              f"(differs in {diff}); evaluate on data made with the checkpoint's crops")
    stream = EpisodeStream(data_dirs, payload["task"], skip_bad=skip_bad, progress=progress)
    result = evaluate(model, stream.batches("all", config.eval_batch_size), config, progress=progress,
                      total=stream.num_batches("all", config.eval_batch_size))
    result["objects"] = stream.counts()["objects"]
    result["task_name"] = payload["task"]
    result["checkpoint"] = str(path)
    return result
