"""TOG-Net speed on this machine: inference latency for 200 candidates and training samples/s.

    .venv/bin/python benchmarks/bench_model.py [--repeats 50] [--steps 20]

Uses the default architecture (ArchConfig()) with random weights (speed does not depend on them) and
prints the median and 90th percentile of each figure, with the machine's load average, since other
jobs on a shared 2-core machine change these numbers a lot.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
import torch

from tognet.model.config import ArchConfig, TrainConfig
from tognet.model.loss import tognet_loss
from tognet.model.network import TOGNet
from tognet.model.predict import TOGNetPredictor
from tognet.model.runtime import tune_allocator


def _stats(ts: list[float]) -> str:
    a = np.array(ts) * 1000
    return f"median {np.median(a):6.2f} ms  p90 {np.percentile(a, 90):6.2f} ms  min {a.min():6.2f} ms"


def bench_inference(repeats: int, threads: int, n: int = 200) -> dict[str, list[float]]:
    """Wall seconds per predict() call, eager and TorchScript interleaved call by call so that other
    jobs on the machine affect both alike."""
    torch.set_num_threads(threads)
    torch.manual_seed(0)
    model = TOGNet(ArchConfig()).eval()
    predictors = {"eager": TOGNetPredictor(model, device="cpu", optimize=False),
                  "torchscript": TOGNetPredictor(model, device="cpu", optimize=True)}
    rng = np.random.default_rng(0)
    crops = rng.normal(0.0, 0.02, size=(n, 64, 64)).astype(np.float32)
    z = rng.uniform(0.6, 1.0, size=n).astype(np.float32)
    out: dict[str, list[float]] = {k: [] for k in predictors}
    for i in range(repeats + 5):
        for kind, predictor in predictors.items():
            t = time.perf_counter()
            predictor.predict(crops, z)
            if i >= 5:  # warm-up calls are not timed
                out[kind].append(time.perf_counter() - t)
    return out


def bench_training(threads: int, steps: int, batch: int) -> float:
    torch.set_num_threads(threads)
    torch.manual_seed(0)
    cfg = TrainConfig()
    model = TOGNet(cfg.arch).train()
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    rng = np.random.default_rng(0)
    crop = torch.from_numpy(rng.normal(0.0, 0.02, size=(batch, 64, 64)).astype(np.float32))
    z = torch.from_numpy(rng.uniform(0.6, 1.0, size=batch).astype(np.float32))
    s_g = torch.from_numpy((rng.random(batch) < 0.5).astype(np.float32))
    s_t = s_g * torch.from_numpy((rng.random(batch) < 0.5).astype(np.float32))
    action = torch.from_numpy(rng.normal(0.0, 0.03, size=(batch, 4)).astype(np.float32))

    def step() -> None:
        out = model(crop, z)
        loss = tognet_loss(out["q_g_logit"], out["q_tg_logit"], model.denormalize_action(out["action_norm"]),
                           s_g, s_t, action, cfg.loss)["loss"]
        opt.zero_grad()
        loss.backward()
        opt.step()

    for _ in range(3):
        step()
    t = time.perf_counter()
    for _ in range(steps):
        step()
    return steps * batch / (time.perf_counter() - t)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=50, help="Timed inference calls per setting.")
    parser.add_argument("--steps", type=int, default=20, help="Timed training steps per setting.")
    parser.add_argument("--batch", type=int, default=128, help="Training batch size.")
    args = parser.parse_args()
    print(f"machine: {os.cpu_count()} cpus, {platform.processor() or platform.machine()}, python "
          f"{platform.python_version()}, torch {torch.__version__}; load average {os.getloadavg()}")
    model = TOGNet(ArchConfig())
    print(f"default architecture: {sum(p.numel() for p in model.parameters())} parameters")
    print("inference, 200 candidates, TOGNetPredictor.predict (BN folded, inference mode, numpy in/out):")
    for allocator in ("glibc default", "tuned"):
        if allocator == "tuned":
            tune_allocator()
        for threads in (1, 2):
            for kind, wall in bench_inference(args.repeats, threads).items():
                print(f"  {allocator:13s} allocator, {kind:11s}, {threads} thread(s): {_stats(wall)}")
    print(f"training, batch {args.batch}, default architecture, Adam step:")
    for threads in (1, 2):
        print(f"  {threads} thread(s): {bench_training(threads, args.steps, args.batch):7.0f} samples/s")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
