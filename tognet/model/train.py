"""Training of one TOG-Net model over episode data (validation split by object, early stopping, resume).

Writes into ``out``::

    config.json     the TrainConfig used
    data.json       description of the dataset folders (shards, counts, sha256)
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
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from tognet.data.episodes import (
    EpisodeArrays,
    dataset_configs,
    describe_dataset,
    read_dataset,
    split_indices_by_object,
)
from tognet.errors import TognetError
from tognet.model.checkpoint import (
    CheckpointError,
    load_checkpoint,
    model_from_checkpoint,
    save_checkpoint,
)
from tognet.model.config import TrainConfig
from tognet.model.loss import masked_sums, reduce_sums, tognet_loss
from tognet.model.metrics import head_metrics
from tognet.model.network import TOGNet, normalization_from_data
from tognet.model.runtime import select_device, set_threads, tune_allocator

#: Config fields that may differ when resuming (everything else must match the checkpoint).
RESUMABLE_CHANGES = ("epochs", "patience", "device", "num_threads", "eval_batch_size")


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


class _Tensors:
    """Episode columns as tensors on a device, indexed by batches."""

    def __init__(self, ep: EpisodeArrays, device: torch.device, storage: str = "float32") -> None:
        self.crop = torch.from_numpy(np.ascontiguousarray(ep.crop, dtype=np.dtype(storage))).to(device)
        self.z = torch.from_numpy(ep.z.astype(np.float32)).to(device)
        self.action = torch.from_numpy(ep.action.astype(np.float32)).to(device)
        self.s_g = torch.from_numpy(ep.grasp_success.astype(np.float32)).to(device)
        self.s_t = torch.from_numpy(ep.task_success.astype(np.float32)).to(device)

    def __len__(self) -> int:
        return int(self.z.shape[0])


def _as_jsonable(x: Any) -> Any:
    if isinstance(x, torch.Tensor):
        return x.item() if x.numel() == 1 else x.tolist()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


@torch.no_grad()
def evaluate(model: TOGNet, data: _Tensors, config: TrainConfig, progress: bool = False) -> dict[str, Any]:
    """Validation loss (components, reduced over the whole set as in training) and per-head metrics."""
    model.eval()
    n = len(data)
    sums = torch.zeros(3, dtype=torch.float64)
    counts = torch.zeros(2, dtype=torch.float64)
    q_g, q_tg, act = [], [], []
    for lo in tqdm(range(0, n, config.eval_batch_size), desc="evaluating", unit="batch", disable=not progress,
                   leave=False, mininterval=1.0):
        sl = slice(lo, lo + config.eval_batch_size)
        out = model(data.crop[sl].float(), data.z[sl])
        a_pred = model.denormalize_action(out["action_norm"])
        terms = masked_sums(out["q_g_logit"], out["q_tg_logit"], a_pred, data.s_g[sl], data.s_t[sl],
                            data.action[sl], config.loss.action_sigma)
        sums += torch.stack(terms[:3]).double().cpu()
        counts += torch.stack(terms[3:]).double().cpu()
        q_g.append(torch.sigmoid(out["q_g_logit"]).cpu())
        q_tg.append(torch.sigmoid(out["q_tg_logit"]).cpu())
        act.append(a_pred.cpu())
    result: dict[str, Any] = {"count": n}
    if n == 0:
        return result
    g, t, a = reduce_sums(sums[0], sums[1], sums[2], n, counts[0], counts[1], config.loss)
    result.update(loss=float(g + t + a), grasp=float(g), task=float(t), action=float(a))
    result["metrics"] = head_metrics(
        torch.cat(q_g).numpy(), torch.cat(q_tg).numpy(), torch.cat(act).numpy(),
        data.s_g.cpu().numpy(), data.s_t.cpu().numpy(), data.action.cpu().numpy(),
    )
    return result


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
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def train(
    data_dirs: Sequence[str | Path],
    task: str,
    out: str | Path,
    config: TrainConfig | None = None,
    *,
    resume: bool = False,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> TrainResult:
    """Train (or resume training) a TOG-Net model on the episodes in ``data_dirs`` for ``task``.

    torch's thread count and deterministic-algorithms setting are changed while training and restored
    afterwards."""
    saved = (torch.get_num_threads(), torch.are_deterministic_algorithms_enabled(),
             torch.is_deterministic_algorithms_warn_only_enabled())
    try:
        return _train(data_dirs, task, out, config, resume=resume, progress=progress, log=log)
    finally:
        torch.set_num_threads(saved[0])
        torch.use_deterministic_algorithms(saved[1], warn_only=saved[2])


def _train(
    data_dirs: Sequence[str | Path],
    task: str,
    out: str | Path,
    config: TrainConfig | None,
    *,
    resume: bool,
    progress: bool,
    log: Callable[[str], None],
) -> TrainResult:
    config = config or TrainConfig()
    out = Path(out)
    last_path, best_path = out / "last.pt", out / "best.pt"
    if out.exists() and not out.is_dir():
        raise TrainingError(f"{out}: exists and is not a folder; pass another --out")
    if not resume and (last_path.exists() or best_path.exists()):
        found = "last.pt" if last_path.exists() else "best.pt"
        raise TrainingError(f"{out}: already holds a training run ({found}); pass --resume or another --out")
    if resume and not last_path.exists():
        raise TrainingError(f"{last_path}: nothing to resume (no last.pt in {out})")
    if config.batch_size < 2:
        raise TrainingError("batch_size must be >= 2 (batch norm needs two samples)")
    # read the run to resume before the (long) data reading, so a bad last.pt fails at once
    payload = load_checkpoint(last_path, map_location="cpu") if resume else None

    seed_everything(config.seed, config.deterministic, config.num_threads)
    tune_allocator()
    device = select_device(config.device)

    episodes = read_dataset(data_dirs, task=task, skip_bad=config.skip_bad_shards, progress=progress)
    if len(episodes) < 2:
        raise TrainingError(f"only {len(episodes)} valid episodes in {list(map(str, data_dirs))}")
    data_desc = describe_dataset(data_dirs)
    crop_config = crop_config_from_data(data_dirs, config.arch)
    if crop_config is None:
        log("note: the datasets saved no CropConfig; the checkpoint cannot tell planners the crops' metric "
            "extent (they will assume the default CropConfig)")
    train_idx, val_idx = split_indices_by_object(episodes.object_id, config.val_fraction, config.seed)
    train_ep, val_ep = episodes.subset(train_idx), episodes.subset(val_idx)
    split = {
        "train_episodes": len(train_ep), "val_episodes": len(val_ep),
        "train_objects": int(len(np.unique(train_ep.object_id))),
        "val_objects": int(len(np.unique(val_ep.object_id))),
        "val_fraction": config.val_fraction, "seed": config.seed,
    }
    if len(train_ep) < 2:
        raise TrainingError(f"only {len(train_ep)} training episodes after the split by object")
    if len(val_ep) == 0:
        warnings.warn("no validation objects (one object, or val_fraction=0): early stopping uses the "
                      "training loss", stacklevel=2)
    train_t = _Tensors(train_ep, device, config.crop_storage)
    val_t = _Tensors(val_ep, device, config.crop_storage)
    del episodes, train_ep, val_ep

    model = TOGNet(config.arch).to(device)
    optimizer = torch.optim.Adam(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    scheduler = torch.optim.lr_scheduler.ExponentialLR(optimizer, gamma=config.lr_decay)
    history: list[dict[str, Any]] = []
    best: dict[str, Any] = {"loss": None, "epoch": 0}
    bad_epochs = 0
    start_epoch = 0

    if payload is not None:
        old: TrainConfig = payload["config_obj"]
        diff = _config_differences(old, config)
        if diff:
            raise CheckpointError(f"{last_path}: config differs from the checkpoint's in {diff}; only "
                                  f"{list(RESUMABLE_CHANGES)} may change on --resume")
        if payload["task"] != task:
            raise CheckpointError(f"{last_path}: trained for task {payload['task']!r}, not {task!r}")
        if _data_fingerprint(payload["data"]) != _data_fingerprint(data_desc):
            raise CheckpointError(f"{last_path}: the dataset changed since this run started (shards or "
                                  "counts differ); start a new run in another --out")
        if payload.get("training") is None:
            raise CheckpointError(f"{last_path}: holds no training state; cannot resume")
        model = model_from_checkpoint(payload, last_path).to(device)
        optimizer = torch.optim.Adam(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
        scheduler = torch.optim.lr_scheduler.ExponentialLR(optimizer, gamma=config.lr_decay)
        tr = payload["training"]
        optimizer.load_state_dict(tr["optimizer"])
        scheduler.load_state_dict(tr["scheduler"])
        torch.set_rng_state(tr["rng_torch"].cpu())
        history = list(tr["history"])
        best = dict(payload["best"])
        bad_epochs = int(tr["bad_epochs"])
        start_epoch = int(payload["epoch"])
        log(f"resuming {out} after epoch {start_epoch} (best val loss {best.get('loss')})")
    else:
        stride = max(1, len(train_t) // 4096)  # crop statistics from at most ~4096 evenly spaced crops
        model.set_normalization(normalization_from_data(train_t.crop[::stride].float(), train_t.z,
                                                        train_t.action, train_t.s_t))
        out.mkdir(parents=True, exist_ok=True)

    config.save(out / "config.json")
    (out / "data.json").write_text(json.dumps({**data_desc, "split": split}, indent=2) + "\n")
    log(f"task {task}: {split['train_episodes']} training episodes ({split['train_objects']} objects), "
        f"{split['val_episodes']} validation ({split['val_objects']} objects), device {device}")

    stopped_early = False
    n_train = len(train_t)
    for epoch in range(start_epoch, config.epochs):
        if bad_epochs >= config.patience:
            stopped_early = True
            break
        model.train()
        perm = np.random.default_rng([config.seed, epoch]).permutation(n_train)
        batches = [perm[i : i + config.batch_size] for i in range(0, n_train, config.batch_size)]
        if len(batches) > 1 and len(batches[-1]) < 2:
            batches.pop()  # batch norm cannot train on a single sample
        sums = {k: 0.0 for k in ("loss", "grasp", "task", "action")}
        t0 = time.perf_counter()
        bar = tqdm(batches, desc=f"epoch {epoch + 1}/{config.epochs}", unit="batch", disable=not progress,
                   leave=False, mininterval=1.0)
        for idx in bar:
            ix = torch.from_numpy(idx).to(device)
            out_b = model(train_t.crop[ix].float(), train_t.z[ix])
            parts = tognet_loss(out_b["q_g_logit"], out_b["q_tg_logit"],
                                model.denormalize_action(out_b["action_norm"]), train_t.s_g[ix],
                                train_t.s_t[ix], train_t.action[ix], config.loss)
            optimizer.zero_grad(set_to_none=True)
            parts["loss"].backward()
            optimizer.step()
            for k in sums:
                sums[k] += float(parts[k].detach()) * len(idx)
            bar.set_postfix(loss=f"{float(parts['loss'].detach()):.4f}", refresh=False)
        seconds = time.perf_counter() - t0
        used = sum(len(b) for b in batches)
        train_stats = {k: v / max(used, 1) for k, v in sums.items()}
        train_stats["samples_per_s"] = used / seconds if seconds > 0 else None
        lr = optimizer.param_groups[0]["lr"]
        scheduler.step()
        val_stats = evaluate(model, val_t, config) if len(val_t) else {"count": 0}
        monitor = val_stats.get("loss", train_stats["loss"])
        record = {"epoch": epoch + 1, "lr": lr, "seconds": seconds, "train": train_stats, "val": val_stats}
        history.append(record)
        if not math.isfinite(monitor):
            raise TrainingError(f"loss is {monitor} at epoch {epoch + 1}; lower the learning rate or check "
                                "the data (last good state: last.pt)")
        improved = best["loss"] is None or monitor < best["loss"] - config.min_delta
        if improved:
            best = {"loss": float(monitor), "epoch": epoch + 1, "monitor": "val" if len(val_t) else "train",
                    "val": val_stats}
            bad_epochs = 0
        else:
            bad_epochs += 1
        common = {"model": model, "config": config, "task": task, "data": data_desc, "split": split,
                  "epoch": epoch + 1, "best": best, "metrics": record, "crop_config": crop_config}
        if improved:
            save_checkpoint(best_path, **common)
        save_checkpoint(last_path, **common, training={
            "optimizer": optimizer.state_dict(), "scheduler": scheduler.state_dict(),
            "rng_torch": torch.get_rng_state(), "history": history, "bad_epochs": bad_epochs,
        })
        _write_metrics(out, history, best, split, task)
        m = val_stats.get("metrics", {})
        log(f"epoch {epoch + 1}: train loss {train_stats['loss']:.4f}, val loss "
            f"{val_stats.get('loss', float('nan')):.4f}, Q_G AUC {_fmt(m.get('grasp', {}).get('auc'))}, "
            f"Q_T|G AUC {_fmt(m.get('task_given_grasp', {}).get('auc'))}"
            f"{' *' if improved else ''} ({train_stats['samples_per_s']:.0f} samples/s)")
        if bad_epochs >= config.patience and epoch + 1 < config.epochs:
            stopped_early = True
            log(f"early stop: no better {best['monitor']} loss for {bad_epochs} epochs (best epoch "
                f"{best['epoch']})")
            break
    if history:
        plot_curves(history, out / "curves.png")
    _write_metrics(out, history, best, split, task, stopped_early=stopped_early)
    if not best_path.exists():
        raise TrainingError(f"{out}: no epoch was trained (epochs={config.epochs})")
    return TrainResult(out=out, best_path=best_path, last_path=last_path, epochs_run=len(history), best=best,
                       stopped_early=stopped_early, history=history)


def _fmt(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.3f}"


def _write_metrics(out: Path, history: list[dict[str, Any]], best: dict[str, Any], split: dict[str, Any],
                   task: str, stopped_early: bool | None = None) -> None:
    payload = {"task": task, "split": split, "best": best, "history": history}
    if stopped_early is not None:
        payload["stopped_early"] = stopped_early
    text = json.dumps(payload, indent=2, default=_as_jsonable, allow_nan=False) + "\n"
    tmp = out / ".metrics.json.tmp"
    tmp.write_text(text)
    os.replace(tmp, out / "metrics.json")


def evaluate_checkpoint(path: str | Path, data_dirs: Sequence[str | Path], *, skip_bad: bool = False,
                        device: str | None = "cpu", progress: bool = False) -> dict[str, Any]:
    """Loss components and per-head metrics of a checkpoint on every valid episode of ``data_dirs``
    (e.g. episodes on held-out test objects). The data must be of the checkpoint's task, and made with
    the checkpoint's CropConfig when both record one."""
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
    episodes = read_dataset(data_dirs, task=payload["task"], skip_bad=skip_bad, progress=progress)
    result = evaluate(model, _Tensors(episodes, dev), config, progress=progress)
    result["objects"] = int(len(np.unique(episodes.object_id)))
    result["task"] = payload["task"]
    result["checkpoint"] = str(path)
    return result
