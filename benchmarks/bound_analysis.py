"""Where a learned method loses to the bound (issue 34 item 3): on the scenes Oracle+ solves and the method
does not, which of Oracle+'s stages found the working plan (``source`` in its records), and, where it kept
the method's own grasp and changed only the motion, how far the working action is from the method's and
how the method's model ranks the two.

Read from an evaluation folder that holds the method's and Oracle+'s records (``tognet evaluate --methods
...,Oracle+``). Classes of a lost scene:

- own plan: Oracle+ took the method's very plan (it won on the search seeds; the evaluation's trial of
  the same plan lost to the execution noise);
- own grasp, other motion: the Oracle's motion from the method's grasp, or a small move of its action;
- its next grasp: the method's own second or third grasp, with its action there;
- other grasp: another method's plan, an alternative grasp, or the wider Oracle search.

With ``--rescore`` each "own grasp, other motion" scene is re-rendered (the evaluation's simulator
settings and scene seed; the depth image's digest is checked against the record) and the method's
action-search model scores both actions at its grasp (Q_T|G,a): "model prefers its own" means the model
ranks the working action lower (its ranking is what is wrong); "search missed" means the model rates the
working action higher and the search did not find it (its budget or proposals are).

    python benchmarks/bound_analysis.py --eval runs/eval-bound --tasks sweeping,pulling [--rescore]
    python benchmarks/bound_analysis.py --eval runs/eval-bound --beyond 10   # is "beyond the bound" luck?
"""

from __future__ import annotations

import argparse
import json
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

import numpy as np

METHOD = "TOG-Net+ActionSearch"
BOUND = "Oracle+"


def records(eval_dir: Path, task: str) -> dict[str, list[dict[str, Any]]]:
    """The task's records by category."""
    out: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for file in sorted((eval_dir / task).glob("*/job-*.json")):
        out[file.parent.name] += json.loads(file.read_text())["records"]
    return out


def lost_scenes(recs: list[dict[str, Any]], method: str) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """(method's record, Oracle+'s record) of the scenes the bound solves and the method does not (both
    trials valid)."""
    by = defaultdict(dict)
    for r in recs:
        by[(r["object_id"], r["scene_seed"])][r["method"]] = r
    out = []
    for pair in by.values():
        m, b = pair.get(method), pair.get(BOUND)
        if m and b and m["valid"] and b["valid"] and b["task_success"] and not m["task_success"]:
            out.append((m, b))
    return out


def kind_of(source: str | None, method: str) -> str:
    """Which class of lost scene a bound's source is (see the module docstring)."""
    if source == method:
        return "own plan"
    source = (source or "").removesuffix(", refined")  # a small move of the action: the grasp is kept
    if source == method:
        return "own grasp, other motion"
    if source == f"Oracle motion from {method}'s grasp":
        return "own grasp, other motion"
    if source.startswith(f"{method} #"):
        return "its next grasp"
    return "other grasp"


def action_gap(m: dict[str, Any], b: dict[str, Any]) -> tuple[float, float]:
    """(start position distance in cm, yaw difference in degrees) between the two actions."""
    a, w = np.asarray(m["action"]), np.asarray(b["action"])
    yaw = (w[3] - a[3] + np.pi) % (2 * np.pi) - np.pi
    return float(100 * np.linalg.norm(w[:3] - a[:3])), float(np.degrees(abs(yaw)))


def rescore(eval_dir: Path, task: str, pairs: list[tuple[dict[str, Any], dict[str, Any]]]
            ) -> list[tuple[float, float]]:
    """(Q_T|G,a of the method's action, of the working action) at the method's grasp, per scene."""
    from tognet.jobs.models import load_model
    from tognet.planning import make_planner

    settings = json.loads((eval_dir / "evaluation.json").read_text())
    model = load_model(settings["models"][f"{task}_search"]["path"])
    cache: dict[str, Any] = {}
    out = []
    for m, b in pairs:
        sim, obs = _scene(eval_dir, task, m, cache)
        planner = make_planner(METHOD, sim.task, search_model=model, config=cache["config"].plan)
        view = planner.view(obs, np.random.default_rng(0), {})
        grasps = np.array([m["grasp"], m["grasp"]], np.float64)
        actions = np.array([m["action"], b["action"]], np.float64)
        own, working = planner.rate(view, grasps, actions, [0.0, 0.0])
        out.append((own["q_t_given_ga"], working["q_t_given_ga"]))
    return out


def _scene(eval_dir: Path, task: str, record: dict[str, Any], cache: dict[str, Any]) -> tuple[Any, Any]:
    """The simulator holding the record's scene and its observation (the evaluation's settings; the depth
    image's digest checked against the record)."""
    from tognet.evaluate.config import EvalConfig
    from tognet.io import short_digest
    from tognet.objects.record import load_catalog
    from tognet.sim import Simulator

    if not cache:
        settings = json.loads((eval_dir / "evaluation.json").read_text())
        cache["config"] = EvalConfig.from_dict(settings["config"])
        cache["objects"] = {o.object_id: o for d in (eval_dir / "objects").iterdir() for o in load_catalog(d)}
    sim = Simulator(cache["config"].sim, task, cache["objects"][record["object_id"]])
    obs = sim.reset(int(record["scene_seed"]))
    if short_digest(np.ascontiguousarray(obs.depth).tobytes()) != record["depth_sha"]:
        raise SystemExit(f"{record['object_id']} scene {record['scene_seed']}: the depth image differs from "
                         "the evaluation's (other simulator settings or code?)")
    return sim, obs


def beyond(eval_dir: Path, task: str, seeds: int, methods: list[str]) -> None:
    """The scenes a method solves and Oracle+ does not: both plans replayed on ``seeds`` fresh
    execution-noise seeds (5000 + k, used by neither the evaluation nor the searches)."""
    from tognet.geometry import Grasp

    cache: dict[str, Any] = {}
    for cat, recs in records(eval_dir, task).items():
        by: dict[tuple[str, int], dict[str, Any]] = defaultdict(dict)
        for r in recs:
            by[(r["object_id"], r["scene_seed"])][r["method"]] = r
        for method in methods:
            rows = [(p[method], p[BOUND]) for p in by.values() if method in p and BOUND in p
                    and p[method]["task_success"] and p[BOUND]["valid"] and not p[BOUND]["task_success"]]
            if not rows:
                continue
            wins = []
            for m, b in rows:
                sim, _ = _scene(eval_dir, task, m, cache)
                won = []
                for r in (m, b):
                    g, a = Grasp.from_array(np.asarray(r["grasp"])), np.asarray(r["action"])
                    won.append(sum(int(sim.execute(g, a, seed=5000 + k).task_success) for k in range(seeds)))
                wins.append(won)
            w = np.array(wins)
            print(f"{task} / {cat}: {method} beyond {BOUND} on {len(rows)} scenes; replayed on {seeds} "
                  f"seeds, its plan wins {w[:, 0].sum()} / {seeds * len(rows)}, {BOUND}'s {w[:, 1].sum()}; "
                  f"its plan the more robust on {int(np.sum(w[:, 0] > w[:, 1]))}")


def report(eval_dir: Path, task: str, method: str, scores: bool) -> None:
    for cat, recs in records(eval_dir, task).items():
        lost = lost_scenes(recs, method)
        kinds = Counter(kind_of(b.get("source"), method) for _, b in lost)
        print(f"\n{task} / {cat}: {len(lost)} scenes {BOUND} solves and {method} does not: "
              + ", ".join(f"{k} {n}" for k, n in kinds.most_common()))
        other = Counter(b.get("source") for _, b in lost if kind_of(b.get("source"), method) == "other grasp")
        if other:
            print("  other grasp, from: " + ", ".join(f"{s} {n}" for s, n in other.most_common(6)))
        motion = [(m, b) for m, b in lost if kind_of(b.get("source"), method) == "own grasp, other motion"]
        if motion:
            gaps = np.array([action_gap(m, b) for m, b in motion])
            print(f"  own grasp, other motion: start moved median {np.median(gaps[:, 0]):.1f} cm "
                  f"(p90 {np.percentile(gaps[:, 0], 90):.1f}), yaw median {np.median(gaps[:, 1]):.0f} deg")
            failures = Counter(m["failure"] for m, _ in motion)
            print("  its failures there: " + ", ".join(f"{k} {n}" for k, n in failures.most_common()))
            if scores:
                q = np.array(rescore(eval_dir, task, motion))
                prefers_own = int(np.sum(q[:, 0] >= q[:, 1]))
                print(f"  Q_T|G,a at its grasp: model prefers its own action on {prefers_own} of {len(q)} "
                      f"(median own {np.median(q[:, 0]):.2f}, working {np.median(q[:, 1]):.2f}); search "
                      f"missed a better-rated action on {len(q) - prefers_own}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--eval", type=Path, required=True, help="the evaluation folder")
    ap.add_argument("--tasks", default="sweeping,hammering,pulling", help="comma-separated tasks")
    ap.add_argument("--method", default=METHOD, help="the method whose lost scenes are looked at")
    ap.add_argument("--rescore", action="store_true", help="rate both actions with the method's model")
    ap.add_argument("--beyond", type=int, default=0, metavar="N",
                    help="replay the scenes each method solves beyond Oracle+ on N fresh noise seeds")
    args = ap.parse_args()
    for task in args.tasks.split(","):
        if args.beyond:
            beyond(args.eval, task, args.beyond, [args.method, "TOG-Net", "Oracle"])
        else:
            report(args.eval, task, args.method, args.rescore and args.method == METHOD)


if __name__ == "__main__":
    main()
