"""One method's task success with a candidate model against the shipped one, paired scene by scene.

    .venv/bin/python benchmarks/model_compare.py SHIPPED_RUN NEW_RUN [--method M] [--task T] [--markdown]

Both folders are ``tognet evaluate --out`` folders of the same tasks, categories and episodes, the second
made with ``--task-model`` naming the candidate: their scenes are the same (test objects, scene seeds, depth
images, execution noise), so every difference is paired. For each task and category, and over all of a
task's categories: both success rates, the difference with a bootstrap 95 % interval (2,000 resamples of
the scenes, seeded) and the scenes only one of the two solves. The shipping rule of the README: a candidate
replaces the shipped model only where the interval of "all" is above zero.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

Key = tuple[str, str, str, int]


def records(run: Path, method: str) -> dict[Key, bool]:
    """Task success of every valid record of ``method`` by (task, category, object id, scene seed)."""
    if not run.is_dir():
        raise SystemExit(f"model_compare: {run} is not an evaluation folder")
    out = {}
    for job in sorted(run.glob("*/*/job-*.json")):
        for r in json.loads(job.read_text())["records"]:
            if r["method"] == method and r["valid"]:
                key = (r["task"], r["category"], r["object_id"], int(r["scene_seed"]))
                out[key] = bool(r["task_success"])
    return out


def bootstrap(old: np.ndarray, new: np.ndarray, resamples: int = 2000, seed: int = 0) -> tuple[float, float]:
    """95 % percentile interval of mean(new - old) over scenes resampled with replacement."""
    d = new.astype(float) - old.astype(float)
    idx = np.random.default_rng(seed).integers(0, len(d), (resamples, len(d)))
    means = d[idx].mean(axis=1)
    return float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def compare(shipped: Path, new: Path, method: str, task: str | None = None) -> list[dict[str, Any]]:
    """One row per (task, category) both runs hold, then one per task over all its categories."""
    a, b = records(shipped, method), records(new, method)
    keys = [k for k in a if k in b and (task is None or k[0] == task)]
    if not keys:
        raise SystemExit(f"model_compare: no scenes of {method} in both {shipped} and {new}")
    groups: dict[tuple[str, str], list[Key]] = {}
    for k in keys:
        groups.setdefault((k[0], k[1]), []).append(k)
        groups.setdefault((k[0], "all"), []).append(k)
    rows = []
    for (t, cat), ks in sorted(groups.items(), key=lambda g: (g[0][0], g[0][1] == "all", g[0][1])):
        old = np.array([a[k] for k in ks])
        nw = np.array([b[k] for k in ks])
        rows.append({"task": t, "category": cat, "scenes": len(ks), "shipped": float(old.mean()),
                     "new": float(nw.mean()), "difference": float(nw.mean() - old.mean()),
                     "ci": bootstrap(old, nw), "only_new": int((nw & ~old).sum()),
                     "only_shipped": int((old & ~nw).sum())})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("shipped", type=Path, help="evaluation folder with the shipped model")
    parser.add_argument("new", type=Path, help="evaluation folder with the candidate (--task-model)")
    parser.add_argument("--method", default="TOG-Net+ActionSearch", help="the method row to compare")
    parser.add_argument("--task", default=None, help="one task only")
    parser.add_argument("--markdown", action="store_true", help="print a markdown table")
    args = parser.parse_args()
    rows = compare(args.shipped, args.new, args.method, args.task)
    if not args.markdown:
        print(json.dumps(rows, indent=1))
        return
    print("| task | category | scenes | shipped | new | new - shipped [95 %] | only new / only shipped |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        lo, hi = r["ci"]
        print(f"| {r['task']} | {r['category']} | {r['scenes']} | {100 * r['shipped']:.1f}"
              f" | {100 * r['new']:.1f} | {100 * r['difference']:+.1f} [{100 * lo:+.1f}, {100 * hi:+.1f}] |"
              f" {r['only_new']} / {r['only_shipped']} |")


if __name__ == "__main__":
    main()
