"""Grasp-candidate pipeline speed: antipodal sampling on a 512 x 424 depth image + 200 crops.

Target (issue 4): sampling and crop extraction together under 20 ms on the dev machine.
Run: .venv/bin/python benchmarks/bench_grasping.py [--repeats 50] [--pin 1]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
import torch

from tognet.grasping import (
    AntipodalConfig,
    CEMConfig,
    CropConfig,
    NMSConfig,
    cem,
    extract_crops,
    nms,
    prepare_depth,
    sample_antipodal,
)
from tognet.grasping.synthetic import Cylinder, render_depth, t_shape, tilted_camera


def _median_ms(fn, repeats: int) -> tuple[float, float, float]:
    """Median and 90th-percentile wall time, and median process CPU time (all threads), in ms."""
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return 1000 * float(np.median(wall)), 1000 * float(np.percentile(wall, 90)), 1000 * float(np.median(cpu))


def _bench_image(label, image, camera, a_cfg, c_cfg, repeats) -> None:
    scene = prepare_depth(image, camera)
    cands = sample_antipodal(scene, None, a_cfg, np.random.default_rng(1))  # warm-up
    extract_crops(scene, None, cands.grasps, c_cfg)
    seeds = iter(range(10_000))
    prep = _median_ms(lambda: prepare_depth(image, camera), repeats)
    samp = _median_ms(
        lambda: sample_antipodal(scene, None, a_cfg, np.random.default_rng(next(seeds))), repeats
    )
    crop = _median_ms(lambda: extract_crops(scene, None, cands.grasps, c_cfg), repeats)

    def full() -> None:
        sc = prepare_depth(image, camera)
        cs = sample_antipodal(sc, None, a_cfg, np.random.default_rng(next(seeds)))
        extract_crops(sc, None, cs.grasps, c_cfg)

    total = _median_ms(full, repeats)
    print(f"[{label}] candidates {len(cands)}")
    for name, r in (
        ("prepare (validate, fill holes, heights)", prep),
        ("sample_antipodal", samp),
        (f"extract_crops x{len(cands)}", crop),
        ("all three from a raw image (target < 20)", total),
    ):
        print(f"  {name:42s} wall {r[0]:6.2f} (p90 {r[1]:6.2f})  cpu {r[2]:6.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=50, help="Timed repetitions per stage.")
    parser.add_argument(
        "--pin",
        type=int,
        default=None,
        help="Pin the process to this CPU core (os.sched_setaffinity) and use one torch thread.",
    )
    args = parser.parse_args()
    if args.pin is not None:
        os.sched_setaffinity(0, {args.pin})
        torch.set_num_threads(1)

    camera = tilted_camera(0.9, x=0.02, y=-0.03, tilt=(np.pi / 70, -np.pi / 90))
    shapes = t_shape(0.02, 0.01, 0.6, handle=(0.26, 0.03, 0.03), head=(0.04, 0.12, 0.035))
    shapes += [Cylinder.lying(-0.2, 0.12, 0.015, 0.2, 1.0)]
    clean = render_depth(camera, shapes)
    holey = clean.copy()
    rng = np.random.default_rng(0)
    holey[rng.random(clean.shape) < 0.02] = 0.0
    holey[150:170, 300:340] = np.nan

    a_cfg, c_cfg = AntipodalConfig(), CropConfig()
    print(
        f"machine: {platform.processor() or platform.machine()}, python {platform.python_version()}, "
        f"numpy {np.__version__}, torch {torch.__version__} ({torch.get_num_threads()} threads)"
    )
    print(
        f"image {clean.shape[1]} x {clean.shape[0]}, {args.repeats} repeats, ms; "
        f"load average {os.getloadavg()[0]:.2f}; cores {sorted(os.sched_getaffinity(0))}"
    )
    for label, image in (("clean", clean), ("2% holes", holey)):
        _bench_image(label, image, camera, a_cfg, c_cfg, args.repeats)

    scene = prepare_depth(clean, camera)
    cands = sample_antipodal(scene, None, a_cfg, np.random.default_rng(1))
    n = _median_ms(lambda: nms(cands.grasps, cands.quality, NMSConfig()), args.repeats)
    target = cands.grasps[0]

    def score(g: np.ndarray) -> np.ndarray:
        return -np.linalg.norm(g[:, :2] - target[:2], axis=1)

    c = _median_ms(lambda: cem(score, cands.grasps, CEMConfig(), np.random.default_rng(0)), args.repeats)
    print(f"nms over {len(cands)}: {n[0]:.2f} ms; cem (3 x 64, trivial scorer): {c[0]:.2f} ms")


if __name__ == "__main__":
    main()
