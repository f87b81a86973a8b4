"""How much of the tool does the grasp-aligned depth crop see? Chooses the crop's metric extent.

    .venv/bin/python benchmarks/crop_coverage.py [--objects 32] [--kinds primitive complex] [--split test]
                                                 [--seed 0] [--out DIR]

Generates ``--objects`` objects per kind (into ``--out``, default a temporary folder). For each object and
each task (hammering, sweeping) it resets the simulator, samples antipodal candidates on the depth image
(both jaw directions) and keeps the NMS modes, the grasps exploration starts from. For each mode it puts
the tool's collision vertices (world pose after settling) in the crop frame (columns along the jaw axis
(cos phi, sin phi), rows along (sin phi, -cos phi), origin at the grasp) and takes the Chebyshev distance
max(|u|, |v|) of the farthest vertex: the half-extent a square crop needs to contain the whole tool.

Prints the number of grasps, percentiles of that needed half-extent, and for candidate full extents the
fraction of grasps whose whole tool fits (needed half-extent <= extent / 2), overall and per kind; the
metres per pixel each extent gives at the crop size (64 px) and the metric side of its centre crop
(32 px); and the tools' lengths (largest xy distance between two vertices as they lie on the table).
Objects the simulator cannot handle (it raises) are skipped and listed.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull

from tognet.grasping import AntipodalConfig, CropConfig, NMSConfig, nms, prepare_depth, sample_antipodal
from tognet.objects import generate_set
from tognet.sim import SimConfig, Simulator
from tognet.tasks import TASK_NAMES

TASKS = TASK_NAMES  # every registered task
EXTENTS = (0.384, 0.45, 0.5, 0.55, 0.6, 0.64, 0.7, 0.768)
PERCENTILES = (50, 75, 90, 95, 99)


def needed_half_extents(xy: NDArray[np.float64], grasps: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N,) Chebyshev distance of the farthest tool point from each grasp, in that grasp's crop frame."""
    d = xy[None, :, :] - grasps[:, None, :2]  # (N, V, 2)
    c, s = np.cos(grasps[:, 3])[:, None], np.sin(grasps[:, 3])[:, None]
    u = d[..., 0] * c + d[..., 1] * s  # columns: along the jaw axis
    v = d[..., 0] * s - d[..., 1] * c  # rows: perpendicular
    return np.max(np.maximum(np.abs(u), np.abs(v)), axis=1)


def tool_length(xy: NDArray[np.float64]) -> float:
    """Largest distance between two of the points (over their convex hull)."""
    hull = xy[ConvexHull(xy).vertices]
    return float(np.max(np.linalg.norm(hull[:, None, :] - hull[None, :, :], axis=-1)))


def measure(kind: str, records: list, seed: int) -> tuple[list[float], list[float], list[str]]:
    """Needed half-extents of every NMS grasp, tool lengths (one per scene) and the skipped scenes."""
    need: list[float] = []
    lengths: list[float] = []
    skipped: list[str] = []
    cfg = SimConfig()
    for k, rec in enumerate(records):
        for t, task in enumerate(TASKS):
            scene_seed = seed * 100_003 + 2 * k + t
            try:
                sim = Simulator(cfg, task, rec)
                obs = sim.reset(scene_seed)
            except Exception as exc:  # any simulator failure: skip the scene, say why
                skipped.append(f"{rec.object_id} {task}: {type(exc).__name__}: {exc}")
                print(f"  skip {rec.object_id} ({task}): {type(exc).__name__}: {exc}", flush=True)
                continue
            rng = np.random.default_rng([seed, k, t])
            scene = prepare_depth(obs.depth, obs.camera)
            cands = sample_antipodal(scene, None, AntipodalConfig(axis_direction="both"), rng)
            pos, rot = sim.object_pose()
            xy = (sim.vertices @ rot.T + pos)[:, :2]
            lengths.append(tool_length(xy))
            if len(cands) == 0:
                continue
            keep = nms(cands.grasps, cands.quality, NMSConfig())
            need.extend(needed_half_extents(xy, cands.grasps[keep]).tolist())
    return need, lengths, skipped


def report(label: str, need: NDArray[np.float64]) -> None:
    """Number of grasps and percentiles of the needed half-extent."""
    if need.size == 0:
        print(f"  {label:9s} no grasps")
        return
    pct = "  ".join(f"p{p}={np.percentile(need, p):.3f}" for p in PERCENTILES)
    print(f"  {label:9s} n={need.size:4d}  {pct}  max={need.max():.3f}")


def fit_table(needs: dict[str, NDArray[np.float64]], size: int, center: int) -> None:
    """Per candidate full extent: the fraction of grasps whose whole tool fits, per group; the resolution."""
    head = "".join(f"{k:>11s}" for k in needs)
    print(f"  extent (m)  half (m){head}   mm/px@{size}  centre {center} px (m)")
    for e in EXTENTS:
        fits = "".join(f"{np.mean(n <= e / 2) if n.size else float('nan'):11.1%}" for n in needs.values())
        print(f"  {e:10.3f}  {e / 2:8.3f}{fits}   {1000 * e / size:8.2f}  {e * center / size:14.3f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--objects", type=int, default=32, help="objects per kind")
    p.add_argument("--kinds", nargs="+", default=["primitive", "complex"], choices=["primitive", "complex"])
    p.add_argument("--split", default="test", choices=["train", "test"])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=None, help="folder for the objects (default: a temp folder)")
    p.add_argument("--workers", type=int, default=1, help="processes for object generation")
    args = p.parse_args()

    t0 = time.perf_counter()
    tmp = None
    if args.out is None:
        tmp = tempfile.TemporaryDirectory(prefix="crop_coverage_")
        out = Path(tmp.name)
    else:
        out = args.out
    all_need: dict[str, NDArray[np.float64]] = {}
    all_len: dict[str, NDArray[np.float64]] = {}
    skipped: list[str] = []
    for kind in args.kinds:
        t = time.perf_counter()
        records = generate_set(
            kind, args.split, args.objects, out / f"{kind}_{args.split}", workers=args.workers
        )
        print(f"{kind}: generated {len(records)} objects in {time.perf_counter() - t:.0f} s", flush=True)
        t = time.perf_counter()
        need, lengths, skip = measure(kind, records, args.seed)
        print(f"{kind}: measured in {time.perf_counter() - t:.0f} s", flush=True)
        all_need[kind], all_len[kind] = np.asarray(need), np.asarray(lengths)
        skipped += skip

    print()
    crop = CropConfig()
    print(
        f"Current crop: {crop.size} px, extent {crop.extent} m (+-{crop.extent / 2:.3f} m), "
        f"{1000 * crop.resolution:.1f} mm/px"
    )
    needs = {"all": np.concatenate(list(all_need.values())), **all_need}
    print("needed half-extent (m) = max over tool vertices of max(|u|, |v|) in the grasp's crop frame:")
    for label, need in needs.items():
        report(label, need)
    print()
    print("fraction of NMS grasps whose whole tool lies inside the crop (needed half-extent <= extent / 2):")
    fit_table(needs, crop.size, crop.center_size)
    print()
    print("tool length (max xy distance between vertices, as settled on the table), m:")
    for label, lens in [("all", np.concatenate(list(all_len.values())))] + list(all_len.items()):
        if lens.size:
            print(f"  {label:9s} n={lens.size:3d}  median={np.median(lens):.3f}  max={lens.max():.3f}")
    if skipped:
        print(f"\nskipped {len(skipped)} scene(s):")
        for s in skipped:
            print(f"  {s}")
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
