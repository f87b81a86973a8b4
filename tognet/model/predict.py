"""Batched inference: score every grasp candidate of an image in one call (used by every planner).

    predictor = TOGNetPredictor.load("runs/sweeping/best.pt")
    pred = predictor.predict(crops, z)          # crops (N, 64, 64) float32, z (N,) metres
    best = pred.q_t.argmax(); action = pred.action_mean[best]

``Prediction`` holds ``q_g`` = Q_G, ``q_t_given_g`` = Q_T|G, ``q_t`` = Q_T|G * Q_G (all (N,), in [0, 1])
and ``action_mean`` (N, 4) = f(o, g) in the stored action units (m, m, m, rad).

From a depth image and grasps directly (crops and z by :mod:`tognet.grasping`)::

    pred = predictor.predict_grasps(scene, grasps)       # scene: DepthScene (or depth + camera=...)
    score = predictor.grasp_score_fn(scene, "task")       # grasps (M, 4) -> Q_T (M,), for CEM
    score = scorer_from_checkpoint("best.pt", scene)      # the same, in one call
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch

from tognet.model.checkpoint import describe, load_checkpoint, model_from_checkpoint
from tognet.model.network import TOGNet, flush_subnormal, fold_batchnorm
from tognet.model.runtime import select_device, set_threads, tune_allocator


@dataclasses.dataclass(frozen=True)
class Prediction:
    """Scores and action means of N grasp candidates."""

    q_g: np.ndarray
    q_t_given_g: np.ndarray
    q_t: np.ndarray
    action_mean: np.ndarray

    def __len__(self) -> int:
        return int(self.q_g.shape[0])


def _optimized(model: TOGNet, device: torch.device) -> Callable[..., dict[str, torch.Tensor]]:
    """``torch.jit.optimize_for_inference`` of a trace of ``model`` (oneDNN layouts, fused conv + ReLU:
    about 1.3-2x faster on this CPU); the eager model if tracing is unavailable or fails."""
    try:
        with warnings.catch_warnings(), torch.inference_mode():
            warnings.simplefilter("ignore")
            s = model.arch.crop_size
            example = (torch.zeros(4, s, s, device=device), torch.full((4,), 0.8, device=device))
            traced = torch.jit.trace(model, example, strict=False, check_trace=False)
            return torch.jit.optimize_for_inference(traced)
    except Exception as exc:  # an optimisation only: never fail loading because of it
        warnings.warn(f"TorchScript optimisation unavailable ({type(exc).__name__}: {exc}); running eager",
                      stacklevel=3)
        return model


@dataclasses.dataclass(frozen=True)
class ActionSearchInputs:
    """What an action-conditioned model computed once per candidate: Q_G (N,), the action mean (N, 4) and
    the grasp's part of the task stream (a tensor, N x hidden)."""

    q_g: np.ndarray
    action_mean: np.ndarray
    encoded: torch.Tensor

    def __len__(self) -> int:
        return int(self.q_g.shape[0])


@dataclasses.dataclass(frozen=True)
class ActionScores:
    """Scores of K actions for each of M grasps: ``success`` Q_T|G,a and ``progress`` (the members' means)
    and ``spread`` (the members' std-dev of Q_T|G,a; zeros for a single member), all (M, K)."""

    success: np.ndarray
    progress: np.ndarray
    spread: np.ndarray


class TOGNetPredictor:
    """A trained TOG-Net in eval mode (batch norm folded, subnormal weights flushed to zero;
    TorchScript-optimised on CPU unless ``optimize=False``) with its checkpoint's self-description in
    ``info``."""

    def __init__(self, model: TOGNet, info: dict[str, Any] | None = None,
                 device: str | torch.device | None = None, optimize: bool = True) -> None:
        self.device = select_device(device if not isinstance(device, torch.device) else str(device))
        self.model = fold_batchnorm(model).to(self.device).eval()
        #: Subnormal weights set to zero in this inference copy (outputs unchanged, several times faster
        #: linear layers on a CPU: :func:`tognet.model.network.flush_subnormal`).
        self.flushed_subnormal = flush_subnormal(self.model)
        self._forward = _optimized(self.model, self.device) if optimize and self.device.type == "cpu" \
            else self.model
        self.info = info or {}
        self.task: str | None = self.info.get("task")
        self.crop_size = model.arch.crop_size
        #: The CropConfig the training crops were made with (from the checkpoint), or None if unknown;
        #: :meth:`predict_grasps` uses it by default so that crops match the training data.
        self.crop_config: Any = None
        if self.info.get("crop_config") is not None:
            from tognet.grasping import CropConfig

            self.crop_config = CropConfig.from_dict(self.info["crop_config"], where="checkpoint crop_config")

    @classmethod
    def load(cls, path: str | Path, device: str | None = None, num_threads: int | None = 1,
             tune_malloc: bool = True, optimize: bool = True) -> TOGNetPredictor:
        """Load a checkpoint (``best.pt`` or ``last.pt``). ``device``: None/'auto' picks CUDA if present.

        ``num_threads`` sets torch's (process-wide) CPU threads, 1 by default: on this 2-core machine
        shared with other jobs, 2 threads had a p90 latency of 0.4-1 s for 200 candidates against
        ~17 ms with 1 (benchmarks/RESULTS.md); pass 2 on an idle machine, None to leave it alone.
        ``tune_malloc`` applies :func:`tognet.model.runtime.tune_allocator`."""
        if num_threads is not None:
            set_threads(num_threads)
        if tune_malloc:
            tune_allocator()
        payload = load_checkpoint(path, map_location="cpu")
        model = model_from_checkpoint(payload, path)
        info = describe(payload)
        info["path"] = str(path)
        return cls(model, info, device, optimize=optimize)

    def _inputs(self, crops: np.ndarray, z: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        crops = np.asarray(crops)
        z = np.asarray(z)
        s = self.crop_size
        if crops.ndim == 4 and crops.shape[1] == 1:
            crops = crops[:, 0]
        if crops.ndim != 3 or crops.shape[1:] != (s, s):
            raise ValueError(f"crops: expected shape (N, {s}, {s}), got {crops.shape}")
        if z.ndim == 2 and z.shape[1] == 1:
            z = z[:, 0]
        if z.ndim != 1 or z.shape[0] != crops.shape[0]:
            raise ValueError(f"z: expected shape ({crops.shape[0]},) to match crops, got {z.shape}")
        if not np.all(np.isfinite(crops)):
            raise ValueError(f"crops: {int((~np.isfinite(crops)).sum())} non-finite values (fill depth holes "
                             "before cropping)")
        if not np.all(np.isfinite(z)):
            raise ValueError("z: non-finite values")
        c = torch.from_numpy(np.ascontiguousarray(crops, dtype=np.float32)).to(self.device)
        zz = torch.from_numpy(np.ascontiguousarray(z, dtype=np.float32)).to(self.device)
        return c, zz

    @torch.inference_mode()
    def predict(self, crops: np.ndarray, z: np.ndarray, batch_size: int = 1024) -> Prediction:
        """Q_G, Q_T|G, Q_T and the action mean for N candidates (one forward pass per ``batch_size``)."""
        c, zz = self._inputs(crops, z)
        n = c.shape[0]
        if n == 0:
            e = np.zeros(0, dtype=np.float32)
            return Prediction(e, e.copy(), e.copy(), np.zeros((0, 4), dtype=np.float32))
        q_g, q_tg, act = [], [], []
        for lo in range(0, n, batch_size):
            out = self._forward(c[lo : lo + batch_size], zz[lo : lo + batch_size])
            q_g.append(torch.sigmoid(out["q_g_logit"]))
            p_tg = torch.sigmoid(out["q_tg_logit"])
            q_tg.append(p_tg.mean(dim=1) if p_tg.dim() == 2 else p_tg)
            act.append(self.model.denormalize_action(out["action_norm"]))
        g = torch.cat(q_g).float().cpu().numpy()
        t = torch.cat(q_tg).float().cpu().numpy()
        a = torch.cat(act).float().cpu().numpy()
        return Prediction(q_g=g, q_t_given_g=t, q_t=g * t, action_mean=a)

    @property
    def action_conditioned(self) -> bool:
        """Whether the task stream sees the action (a model of the learned action search)."""
        return bool(self.model.action_conditioned)

    @torch.inference_mode()
    def encode(self, crops: np.ndarray, z: np.ndarray) -> ActionSearchInputs:
        """For an action-conditioned model: Q_G, the action mean and the grasp's part of the task stream
        for N candidates, to score many actions each with :meth:`score_actions`."""
        if not self.action_conditioned:
            raise ValueError(f"{self.info.get('path', 'this model')}: its task stream does not see the "
                             "action (trained with ArchConfig.task_head='policy'); the action search needs "
                             "one trained with task_head='action'")
        c, zz = self._inputs(crops, z)
        out = self.model.encode_task(c, zz)
        return ActionSearchInputs(q_g=torch.sigmoid(out["q_g_logit"]).float().cpu().numpy(),
                                  action_mean=self.model.denormalize_action(out["action_norm"]).float().cpu()
                                  .numpy(), encoded=out["encoded"])

    @torch.inference_mode()
    def score_actions(self, inputs: ActionSearchInputs, actions: np.ndarray,
                      rows: np.ndarray | None = None) -> ActionScores:
        """Q_T|G,a and the predicted progress (the members' means, (M, K)) and the members' spread of Q_T|G,a
        of actions (M, K, 4) (stored units) for the encoded candidates ``rows`` (M indices; default all)."""
        enc = inputs.encoded
        if rows is not None:
            enc = enc[torch.as_tensor(np.asarray(rows), dtype=torch.long)]
        a = torch.from_numpy(np.ascontiguousarray(actions, dtype=np.float32)).to(self.device)
        if a.dim() != 3 or a.shape[0] != enc.shape[0] or a.shape[2] != 4:
            raise ValueError(f"actions: expected shape ({enc.shape[0]}, K, 4), got {tuple(a.shape)}")
        p = torch.sigmoid(self.model.score_actions(enc, a)).float()  # (M, K, members, 2)
        spread = p[..., 0].std(dim=2, unbiased=False) if p.shape[2] > 1 else torch.zeros_like(p[..., 0, 0])
        return ActionScores(p[..., 0].mean(dim=2).cpu().numpy(), p[..., 1].mean(dim=2).cpu().numpy(),
                            spread.cpu().numpy())

    def score_fn(self, kind: Literal["task", "grasp", "task_given_grasp"] = "task"
                 ) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        """A function (crops, z) -> scores (N,): Q_T ('task'), Q_G ('grasp') or Q_T|G. For CEM, wrap it
        with the crop extraction that turns grasps into (crops, z)."""
        field = {"task": "q_t", "grasp": "q_g", "task_given_grasp": "q_t_given_g"}
        if kind not in field:
            raise ValueError(f"kind must be one of {list(field)}, got {kind!r}")

        def score(crops: np.ndarray, z: np.ndarray) -> np.ndarray:
            return getattr(self.predict(crops, z), field[kind])

        return score

    def predict_grasps(self, scene: Any, grasps: np.ndarray, camera: Any = None,
                       crop_config: Any = None) -> Prediction:
        """Predict for world grasps (M, 4) on a depth image: ``scene`` is a prepared
        :class:`tognet.grasping.DepthScene` (or a raw depth image with ``camera``). Crops come from
        :func:`tognet.grasping.extract_crops` with ``crop_config``: by default the checkpoint's (the one its
        training crops were made with, :attr:`crop_config`), else CropConfig() with this model's crop
        sizes; z from :func:`tognet.grasping.grasp_depths`."""
        from tognet.grasping import extract_crops, grasp_depths, prepare_depth
        from tognet.grasping.crops import resolve_crop

        scene = prepare_depth(scene, camera)
        cfg = resolve_crop([self], crop_config)
        grasps = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
        crops = extract_crops(scene, None, grasps, cfg)
        return self.predict(crops, grasp_depths(scene.camera, grasps).astype(np.float32))

    def grasp_score_fn(self, scene: Any, kind: Literal["task", "grasp", "task_given_grasp"] = "task",
                       camera: Any = None, crop_config: Any = None) -> Callable[[np.ndarray], np.ndarray]:
        """A function grasps (M, 4) -> scores (M,) float64 on one depth image (the CEM's ``score_fn``)."""
        field = {"task": "q_t", "grasp": "q_g", "task_given_grasp": "q_t_given_g"}
        if kind not in field:
            raise ValueError(f"kind must be one of {list(field)}, got {kind!r}")
        from tognet.grasping import prepare_depth

        scene = prepare_depth(scene, camera)

        def score(grasps: np.ndarray) -> np.ndarray:
            pred = self.predict_grasps(scene, grasps, crop_config=crop_config)
            return getattr(pred, field[kind]).astype(np.float64)

        return score


def scorer_from_checkpoint(
    path: str | Path, scene: Any, kind: Literal["task", "grasp", "task_given_grasp"] = "task"
) -> Callable[[np.ndarray], np.ndarray]:
    """Load a checkpoint and return its ``grasps (M, 4) -> scores (M,)`` function on ``scene``
    (the hook ``tognet grasps --checkpoint`` calls)."""
    return TOGNetPredictor.load(path).grasp_score_fn(scene, kind)
