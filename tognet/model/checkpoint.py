"""Self-describing checkpoints.

A checkpoint is a ``torch.save`` dict (loaded with ``weights_only=True``: plain data and tensors only)::

    format, format_version          "tognet-checkpoint", FORMAT_VERSION
    task                            task name (one model per task)
    config                          TrainConfig as a dict (architecture and loss inside)
    arch                            ArchConfig as a dict (repeated for readers that only build the net)
    normalization                   crop/z mean and std, action mean and std per dim
    data                            dataset description: dirs, shard files, counts, sha256, totals
    crop_config                     CropConfig (size, metric extent, ...) the training crops were made
                                    with (from the datasets' saved configs); None if they saved none
    split                           train/validation object and episode counts
    code                            tognet version, git commit (if available), torch version
    created                         UTC time
    state_dict                      model weights and normalisation buffers
    epoch, best, metrics            epochs completed, best validation record, latest metrics
    training                        (last.pt only) optimiser, scheduler, RNG states, history, patience

Reading a checkpoint of another format version, or whose config lacks an architecture or loss field this
code's TrainConfig has (written by an older tognet) or has one it does not know, raises
:class:`CheckpointError` with the reason; so does a truncated or corrupt file, or weights that do not fit
the recorded architecture. A missing *training-loop* field (one added later, e.g. a data-loading setting)
takes its default and is listed in ``payload["defaults_filled"]``: it cannot change what the network
computes; so does an architecture or loss field in :data:`SAME_AS_BEFORE`, whose value there is how older
checkpoints were trained.
"""

from __future__ import annotations

import datetime as _dt
import functools
import hashlib
import io
import json
import subprocess
from pathlib import Path
from typing import Any

import torch

import tognet
from tognet.config import ConfigError
from tognet.errors import TognetError
from tognet.io import atomic_write_bytes, sha256_file
from tognet.model.config import ArchConfig, TrainConfig
from tognet.model.network import TOGNet
from tognet.tasks import GRASP_ONLY

FORMAT = "tognet-checkpoint"
FORMAT_VERSION = 1


class CheckpointError(TognetError):
    """A checkpoint is missing, corrupt, of another format version or does not match this code."""


#: Nested config fields added after checkpoints existed, with the value that reproduces how those older
#: checkpoints were trained (so a missing one is filled in, not refused).
SAME_AS_BEFORE: dict[str, object] = {
    "loss.action_sigma_source": "fixed",
    # the action-conditioned task stream came later: every older model is the paper's
    "arch.task_head": "policy", "arch.action_features": 32, "arch.action_hidden": 128,
    "arch.action_members": 1,
    "loss.weight_progress": 0.5,
}


@functools.lru_cache(maxsize=1)
def code_version() -> dict[str, Any]:
    """tognet version, git commit of the source tree (None outside a git checkout) and torch version."""
    root = Path(tognet.__file__).resolve().parent.parent
    commit: str | None = None
    dirty: bool | None = None
    try:
        out = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=5, check=False)
        if out.returncode == 0:
            commit = out.stdout.strip()
            st = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no",
                                 "--", "tognet"], capture_output=True, text=True, timeout=5, check=False)
            dirty = bool(st.stdout.strip()) if st.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        pass
    return {"tognet": tognet.__version__, "git_commit": commit, "git_dirty": dirty,
            "torch": str(torch.__version__)}


#: Payload keys outside the content digest: the digest itself, the time of writing, and what loading adds.
_UNDIGESTED = ("digest", "created", "config_obj", "crop_config_obj", "defaults_filled", "verified")


def content_digest(payload: dict[str, Any]) -> str:
    """The sha256 of a checkpoint's content: its settings and descriptions (canonical JSON) and every
    tensor's name, dtype, shape and bytes. The time of writing is left out, so the same training gives
    the same digest."""
    h = hashlib.sha256()
    meta = {k: v for k, v in payload.items() if k not in _UNDIGESTED and k != "state_dict"}
    h.update(json.dumps(meta, sort_keys=True, default=str).encode())
    for name in sorted(payload.get("state_dict", {})):
        t = payload["state_dict"][name].detach().cpu().contiguous()
        h.update(f"{name}|{t.dtype}|{tuple(t.shape)}|".encode())
        h.update(t.reshape(-1).view(torch.uint8).numpy().tobytes())
    return h.hexdigest()


def _verify(path: Path, payload: dict[str, Any]) -> str:
    """How the checkpoint's bytes were checked ("digest"; "shipped": a model in tognet/models, its file's
    sha256 against its .json as well as its digest; "none" for one written before checkpoints carried a
    digest); CheckpointError when they do not match."""
    recorded = payload.get("digest")
    if recorded is not None and content_digest(payload) != recorded:
        raise CheckpointError(f"{path}: its content does not match the digest written into it (corrupt, "
                              "or edited?); use another copy or retrain")
    shipped = _shipped_digest(path)
    if shipped is not None:
        if sha256_file(path) != shipped:
            raise CheckpointError(f"{path}: a shipped model whose bytes do not match the sha256 in "
                                  f"{path.with_suffix('.json').name} (corrupt?); reinstall tognet")
        return "shipped"
    return "none" if recorded is None else "digest"


def _shipped_digest(path: Path) -> str | None:
    """The sha256 recorded for a shipped model (tognet/models/<name>.json), None for any other file."""
    from tognet.models import MODELS_DIR

    if path.resolve().parent != MODELS_DIR or not path.with_suffix(".json").is_file():
        return None
    try:
        return json.loads(path.with_suffix(".json").read_text()).get("sha256")
    except (OSError, ValueError):
        return None


def save_checkpoint(
    path: str | Path,
    *,
    model: TOGNet,
    config: TrainConfig,
    task: str,
    data: dict[str, Any],
    split: dict[str, Any] | None = None,
    epoch: int = 0,
    best: dict[str, Any] | None = None,
    metrics: dict[str, Any] | None = None,
    training: dict[str, Any] | None = None,
    crop_config: dict[str, Any] | None = None,
) -> Path:
    """Write a checkpoint atomically (temporary file, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "task": task,
        "config": config.to_dict(),
        "arch": config.arch.to_dict(),
        "normalization": model.normalization(),
        "data": data,
        "crop_config": crop_config,
        "split": split or {},
        "code": dict(code_version()),
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "state_dict": {k: v.detach().cpu() for k, v in model.state_dict().items()},
        "epoch": int(epoch),
        "best": best or {},
        "metrics": metrics or {},
        "training": training,
    }
    payload["digest"] = content_digest(payload)
    buffer = io.BytesIO()  # serialised in memory first: a full disk is then a plain OSError naming the
    torch.save(payload, buffer)  # file, not an error from inside torch's zip writer
    atomic_write_bytes(path, buffer.getvalue(), fsync=False)
    return path


def load_checkpoint(path: str | Path, map_location: str | torch.device = "cpu") -> dict[str, Any]:
    """Read and validate a checkpoint; adds ``config_obj`` (TrainConfig). Raises CheckpointError."""
    path = Path(path)
    if path.is_dir():
        raise CheckpointError(f"{path}: is a folder, not a checkpoint file (e.g. {path / 'best.pt'})")
    if not path.is_file():
        raise CheckpointError(f"{path}: checkpoint file not found")
    try:
        payload = torch.load(path, map_location=map_location, weights_only=True)
    except Exception as exc:  # torch raises many types for a bad file (pickle, zip, runtime errors)
        raise CheckpointError(
            f"{path}: not a readable checkpoint (corrupt or truncated?): {_short_reason(exc)}"
        ) from exc
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not a tognet checkpoint (no '{FORMAT}' header)")
    version = payload.get("format_version")
    if version != FORMAT_VERSION:
        raise CheckpointError(
            f"{path}: checkpoint format version {version!r}, this tognet "
            f"({tognet.__version__}) reads version {FORMAT_VERSION}; retrain the model with this version"
        )
    payload["verified"] = _verify(path, payload)
    written_by = payload.get("code", {})
    defaults = TrainConfig().to_dict()
    missing = _missing_keys(payload.get("config", {}), defaults)
    # top-level training-loop settings (not the architecture or the loss)
    filled = [k for k in missing if "." not in k and not isinstance(defaults[k], dict)]
    if filled and isinstance(payload.get("config"), dict):
        payload["config"] = {**payload["config"], **{k: defaults[k] for k in filled}}
    # loss fields added later whose default is what every older checkpoint was trained with
    older = [k for k in missing if k in SAME_AS_BEFORE]
    if older and isinstance(payload.get("config"), dict):
        cfg = dict(payload["config"])
        for key in older:
            section, name = key.split(".")
            cfg[section] = {**cfg.get(section, {}), name: SAME_AS_BEFORE[key]}
            if section == "arch" and isinstance(payload.get("arch"), dict):
                payload["arch"] = {**payload["arch"], name: SAME_AS_BEFORE[key]}
        payload["config"] = cfg
        filled = filled + older
    payload["defaults_filled"] = filled
    missing = [k for k in missing if k not in filled]
    if missing:
        raise CheckpointError(
            f"{path}: its config lacks {missing}, fields this tognet ({tognet.__version__}) needs; it was "
            f"written by an older tognet {written_by.get('tognet')} (commit {written_by.get('git_commit')}); "
            "retrain the model with this version"
        )
    try:
        config = TrainConfig.from_dict(payload["config"], where=f"{path}:config")
        arch = ArchConfig.from_dict(payload["arch"], where=f"{path}:arch")
    except (ConfigError, KeyError) as exc:
        raise CheckpointError(
            f"{path}: its config does not match this tognet's TrainConfig ({exc}); it was written by "
            f"tognet {written_by.get('tognet')} (commit {written_by.get('git_commit')})"
        ) from exc
    if arch != config.arch:
        raise CheckpointError(f"{path}: 'arch' and 'config.arch' disagree; the file was edited or is corrupt")
    payload.setdefault("crop_config", None)
    if payload["crop_config"] is not None:
        from tognet.grasping.crops import CropConfig

        try:
            crop = CropConfig.from_dict(payload["crop_config"], where=f"{path}:crop_config")
        except ConfigError as exc:
            raise CheckpointError(f"{path}: its crop_config does not match this tognet's CropConfig ({exc})"
                                  ) from exc
        if crop.size != arch.crop_size:
            raise CheckpointError(f"{path}: crop_config.size={crop.size} but the network takes "
                                  f"{arch.crop_size}-pixel crops")
        payload["crop_config_obj"] = crop
    payload["config_obj"] = config
    return payload


def _short_reason(exc: BaseException) -> str:
    """One short line for torch's (long, multi-line, advice-laden) load errors."""
    text = str(exc)
    if "Weights only load failed" in text:
        return f"{type(exc).__name__}: not a torch file, or it holds objects other than data and tensors"
    first = text.strip().splitlines()[0] if text.strip() else ""
    first = first.split(". ")[0]
    return f"{type(exc).__name__}: {first[:120]}" if first else type(exc).__name__


def _missing_keys(data: Any, reference: dict[str, Any], prefix: str = "") -> list[str]:
    """Keys of ``reference`` (recursively) absent from ``data``."""
    if not isinstance(data, dict):
        return []
    out = []
    for key, value in reference.items():
        if key not in data:
            out.append(prefix + key)
        elif isinstance(value, dict):
            out.extend(_missing_keys(data[key], value, f"{prefix}{key}."))
    return out


def model_from_checkpoint(payload: dict[str, Any], path: str | Path = "<checkpoint>") -> TOGNet:
    """Build the network of a loaded checkpoint and load its weights (strict)."""
    model = TOGNet(payload["config_obj"].arch)
    try:
        model.load_state_dict(payload["state_dict"], strict=True)
    except (RuntimeError, KeyError) as exc:
        raise CheckpointError(f"{path}: weights do not match the architecture in its config: {exc}") from exc
    return model


def describe(payload: dict[str, Any]) -> dict[str, Any]:
    """The self-description of a loaded checkpoint (everything but tensors), JSON-ready."""
    hidden = ("state_dict", "training", "config_obj", "crop_config_obj")
    out = {k: v for k, v in payload.items() if k not in hidden}
    buffers = {"crop_mean", "crop_std", "z_mean", "z_std", "action_mean", "action_std"}
    out["parameters"] = int(sum(v.numel() for k, v in payload["state_dict"].items()
                                if not k.endswith(("running_mean", "running_var", "num_batches_tracked"))
                                and k not in buffers))
    out["resumable"] = payload.get("training") is not None
    return out


def check_model_role(path: str | Path, task: str, option: str, *, action_search: bool | None = None,
                     context: str = "") -> dict[str, Any]:
    """Read the checkpoint ``path`` given as ``option`` and check it is a model of ``task`` (``grasping``:
    the grasp-only model); with ``action_search`` True its task stream must see the action
    (``ArchConfig.task_head='action'``), with False it must not. Returns the payload; a checkpoint that is
    missing, unreadable, of another task or of the other head raises :class:`CheckpointError` naming the
    option, the file and what was expected (``context``, e.g. ``" for --task hammering"``), before any
    work."""
    payload = load_checkpoint(path)
    have = payload.get("task")
    what = "the grasp-only model" if task == GRASP_ONLY else f"a {task} model"
    if have != task:
        found = "the grasp-only model (task 'grasping')" if have == GRASP_ONLY else f"a {have} model"
        raise CheckpointError(f"{option} {path} is {found}; {option} must be {what}{context}")
    head = payload["config_obj"].arch.task_head
    if action_search is True and head != "action":
        raise CheckpointError(f"{option} {path}: its task stream does not see the action "
                              f"(task_head={head!r}); the action search needs a model trained with "
                              "ArchConfig.task_head='action'")
    if action_search is False and head == "action":
        raise CheckpointError(f"{option} {path}: an action-search model (task_head='action'); {option} takes "
                              "a TOG-Net model (task_head='policy')")
    return payload
