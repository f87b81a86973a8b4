"""Each method's task success with an arm against the floating gripper on the same scenes, and why it differs.

    .venv/bin/python benchmarks/arm_compare.py FLOATING_RUN ARM_RUN [--markdown]

Both folders are ``tognet evaluate --out`` folders made with the same tasks, categories, episodes and
models, one without ``--robot`` and one with it: their scenes are the same (the same test objects, scene
seeds, depth images and execution noise), so every difference is paired, scene by scene (Newcombe's
interval for paired proportions, as the evaluation's own comparisons). For each task, category and method:
the two success rates, the arm minus the floating gripper, and the failure reasons of the scenes that
succeeded with the floating gripper and failed with the arm (reach, joint limits, collisions, ...). Also the
execute time per episode of each run (from the records; the machine's load at the time counts).
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from tognet.evaluate.stats import paired_difference


def _records(run: Path) -> dict[tuple[str, str, str, str, int], dict[str, Any]]:
    """Every valid record of a run by (task, category, method, object id, scene seed)."""
    out = {}
    for job in sorted(run.glob("*/*/job-*.json")):
        for r in json.loads(job.read_text())["records"]:
            out[(r["task"], r["category"], r["method"], r["object_id"], int(r["scene_seed"]))] = r
    return out


def compare(floating: Path, arm: Path) -> list[dict[str, Any]]:
    """One row per (task, category, method) present in both runs."""
    a, b = _records(floating), _records(arm)
    groups: dict[tuple[str, str, str], list[tuple[dict[str, Any], dict[str, Any]]]] = {}
    for key, ra in a.items():
        rb = b.get(key)
        if rb is not None and ra["valid"] and rb["valid"]:
            groups.setdefault(key[:3], []).append((ra, rb))
    rows = []
    for (task, category, method), pairs in sorted(groups.items()):
        fs = np.array([p[0]["task_success"] for p in pairs], dtype=bool)
        ars = np.array([p[1]["task_success"] for p in pairs], dtype=bool)
        diff = paired_difference(ars, fs)
        lost = Counter(p[1]["failure"] for p in pairs if p[0]["task_success"] and not p[1]["task_success"])
        arm_failures = Counter(p[1]["failure"] for p in pairs if not p[1]["task_success"])
        rows.append({
            "task": task, "category": category, "method": method, "scenes": len(pairs),
            "floating": float(fs.mean()), "arm": float(ars.mean()), "difference": diff["difference"],
            "ci": diff["ci"], "lost": dict(lost.most_common()), "gained": int(diff["first_only"]),
            "arm_failures": dict(arm_failures.most_common()),
            "execute_s": (float(np.nanmean([p[0].get("execute_seconds", np.nan) for p in pairs])),
                          float(np.nanmean([p[1].get("execute_seconds", np.nan) for p in pairs]))),
        })
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("floating", type=Path, help="evaluation folder without --robot")
    parser.add_argument("arm", type=Path, help="evaluation folder with --robot, the same settings otherwise")
    parser.add_argument("--markdown", action="store_true", help="print a markdown table")
    args = parser.parse_args()
    for run in (args.floating, args.arm):
        if not (run / "evaluation.json").is_file():
            parser.error(f"{run} holds no evaluation (no evaluation.json)")
    rows = compare(args.floating, args.arm)
    if not rows:
        parser.error("the two runs share no scenes: were they made with the same settings?")
    if args.markdown:
        print("| task | category | method | floating % | arm % | arm - floating [95 %] | lost with the arm "
              "(why) |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        lo, hi = r["ci"]
        why = ", ".join(f"{k} {v}" for k, v in r["lost"].items()) or "-"
        if args.markdown:
            print(f"| {r['task']} | {r['category']} | {r['method']} | {100 * r['floating']:.1f} | "
                  f"{100 * r['arm']:.1f} | {100 * r['difference']:+.1f} [{100 * lo:+.1f}, {100 * hi:+.1f}] | "
                  f"{why}; gained {r['gained']} |")
        else:
            print(f"{r['task']:9s} {r['category']:12s} {r['method']:32s} {100 * r['floating']:5.1f} -> "
                  f"{100 * r['arm']:5.1f} ({100 * r['difference']:+.1f} [{100 * lo:+.1f}, {100 * hi:+.1f}], "
                  f"{r['scenes']} scenes) lost: {why}; gained {r['gained']}; execute "
                  f"{1000 * r['execute_s'][0]:.0f} -> {1000 * r['execute_s'][1]:.0f} ms")


if __name__ == "__main__":
    main()
