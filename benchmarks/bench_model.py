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


def bench_inference(threads: int, repeats: int, n: int = 200) -> list[float]:
    torch.set_num_threads(threads)
    torch.manual_seed(0)
    predictor = TOGNetPredictor(TOGNet(ArchConfig()).eval(), device="cpu")
    rng = np.random.default_rng(0)
    crops = rng.normal(0.0, 0.02, size=(n, 64, 64)).astype(np.float32)
    z = rng.uniform(0.6, 1.0, size=n).astype(np.float32)
    for _ in range(5):
        predictor.predict(crops, z)
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        predictor.predict(crops, z)
        ts.append(time.perf_counter() - t)
    return ts


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
    print("inference, 200 candidates, TOGNetPredictor.predict (BN folded, inference mode):")
    for threads in (1, 2):
        ts = bench_inference(threads, args.repeats)
        print(f"  glibc default allocator, {threads} thread(s): {_stats(ts)}")
    tuned = tune_allocator()
    for threads in (1, 2):
        ts = bench_inference(threads, args.repeats)
        print(f"  tuned allocator ({tuned}),  {threads} thread(s): {_stats(ts)}")
    print(f"training, batch {args.batch}, default architecture, Adam step:")
    for threads in (1, 2):
        print(f"  {threads} thread(s): {bench_training(threads, args.steps, args.batch):7.0f} samples/s")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
