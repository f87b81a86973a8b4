"""How the action search should choose its grasp (issue 34 item 3): measured offline, on objects from the
training generator that no shipped model was trained or tested on.

For each scene, the shipped action-search model rates every antipodal candidate as the planner does
(Q_G times the best of its rating actions), the ``--top`` best-rated candidates get the planner's action
search each, and every one of those (grasp, action) pairs is executed on ``--seeds`` execution-noise seeds.
That gives each candidate's success rate, so every ranking rule over the same candidates can be scored on
the same trials (a paired comparison): the planner's rule (the best Q_G * Q_T|G,a of the ``refine_grasps``
best-rated), other weightings of the two streams, more candidates searched, and the best any ranking of
these candidates could do (the ceiling of a change to the ranking alone).

Objects: the training split from index ``--start`` on (the shipped search models trained on indices
0-149 of each kind, the README's test sets are the test split), so a rule chosen here is chosen on
training-distribution objects only. Writes one JSON line per scene to ``--out`` (resumes from it).

    python benchmarks/search_rerank.py --task hammering --objects 30 --scenes 2 --out runs/rerank/h.jsonl
    python benchmarks/search_rerank.py --summary runs/rerank/h.jsonl
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

RULES: dict[str, str] = {
    "planner": "the planner's rule: best Q_G * Q_T|G,a of the 4 best-rated",
    "top8": "best Q_G * Q_T|G,a of the 8 best-rated",
    "top12": "best Q_G * Q_T|G,a of all searched",
    "qt_only4": "best Q_T|G,a of the 4 best-rated",
    "qg_sqrt4": "best sqrt(Q_G) * Q_T|G,a of the 4 best-rated",
    "qg_sq4": "best Q_G^2 * Q_T|G,a of the 4 best-rated",
    "qg_sqrt12": "best sqrt(Q_G) * Q_T|G,a of all searched",
    "qt_gate12": "best Q_T|G,a of all searched with Q_G >= 0.8 (else the planner's)",
    "rating1": "the best-rated candidate (its searched action)",
    "progress4": "best Q_G * (Q_T|G,a + 0.5 progress) of the 4 best-rated",
    "robust4": "best Q_G * Q_T|G,a averaged over the grasp's execution noise, of the 4 best-rated",
    "robust12": "the same, of all searched",
    "robust_min4": "best worst case of Q_G * Q_T|G,a over the grasp's noise, of the 4 best-rated",
}


def robust_value(model: Any, view: Any, grasps: Any, acts: Any, episode: Any, rng: np.random.Generator,
                 k: int = 8) -> tuple[list[float], list[float]]:
    """Mean and minimum of Q_G * Q_T|G,a over ``k`` draws of the execution's grasp noise in x, y and yaw
    (``episode``: the simulator's :class:`EpisodeConfig`) around each grasp, its action kept."""
    n = len(grasps)
    xy, yaw = episode.grasp_position_noise, episode.grasp_yaw_noise
    shake = rng.uniform(-1, 1, (n, k, 4)) * np.array([xy, xy, 0.0, yaw])
    moved = (grasps[:, None, :] + shake).reshape(n * k, 4)
    crops, z = view.crops(moved)
    enc = model.encode(crops, z)
    success = np.asarray(model.score_actions(enc, np.repeat(acts, k, axis=0)[:, None, :]).success)[:, 0]
    value = (enc.q_g.astype(np.float64) * success).reshape(n, k)
    return value.mean(axis=1).tolist(), value.min(axis=1).tolist()


def scene_rows(sim: Any, planner: Any, model: Any, obs: Any, top: int, seeds: int, rng: np.random.Generator,
               execute: bool = True) -> dict[str, Any]:
    """The ``top`` best-rated candidates of one scene: their scores and their success on ``seeds`` seeds
    (no trials without ``execute``: the scores only)."""
    from tognet.geometry import Grasp
    from tognet.policies.action_search import rate_candidates, refine_actions

    view = planner.view(obs, rng, {})
    task, cfg = view.task, planner.grasp_policy.config
    grasps = view.candidates.grasps
    crops, z = view.crops(grasps)
    low, high = np.asarray(task.action_low, np.float64), np.asarray(task.action_high, np.float64)
    enc, rate_a, rate_s, (lo, hi) = rate_candidates(model, crops, z, low, high, cfg, rng)
    rating = enc.q_g.astype(np.float64) * rate_s
    rows = np.argsort(-rating, kind="stable")[:top]
    acts, succ = refine_actions(model, enc, rows, rate_a[rows], lo[rows], hi[rows], cfg, rng)
    scores = model.score_actions(enc, acts[:, None, :], rows)
    outcomes = []
    for g, a in zip(grasps[rows] if execute else [], acts, strict=False):
        grasp = Grasp.from_array(np.asarray(g, np.float64))
        outcomes.append([int(sim.execute(grasp, a, seed=100 + k).task_success) for k in range(seeds)])
    progress = np.asarray(scores.progress)[:, 0]
    q_g = enc.q_g[rows].astype(float)
    mean, low = robust_value(model, view, grasps[rows], acts, sim.config.episode, rng)
    return {"robust": mean, "robust_min": low,
            "n": int(len(grasps)), "rating": rating[rows].tolist(), "q_g": q_g.tolist(),
            "q_t": succ.astype(float).tolist(), "progress": progress.astype(float).tolist(),
            "quality": view.candidates.quality[rows].astype(float).tolist(),
            "wins": [sum(o) for o in outcomes], "outcomes": outcomes, "seeds": seeds}


def _values(row: dict[str, Any]) -> dict[str, tuple[int, Any]]:
    """Each rule's (candidates it looks at, value it maximises)."""
    q_g, q_t, prog = np.asarray(row["q_g"]), np.asarray(row["q_t"]), np.asarray(row["progress"])
    n = len(q_g)
    gate = np.where(q_g >= 0.8, q_t, -1.0) if (q_g >= 0.8).any() else None
    return {"planner": (4, q_g * q_t), "top8": (8, q_g * q_t), "top12": (n, q_g * q_t), "qt_only4": (4, q_t),
            "qg_sqrt4": (4, np.sqrt(q_g) * q_t), "qg_sq4": (4, q_g ** 2 * q_t),
            "qg_sqrt12": (n, np.sqrt(q_g) * q_t),
            "qt_gate12": (n, gate) if gate is not None else (4, q_g * q_t),
            "progress4": (4, q_g * (q_t + 0.5 * prog)), "rating1": (1, np.zeros(n)),
            "robust4": (4, np.asarray(row["robust"])), "robust12": (n, np.asarray(row["robust"])),
            "robust_min4": (4, np.asarray(row["robust_min"]))}


def pick(rule: str, row: dict[str, Any]) -> int:
    """The index (into the scene's searched candidates, best-rated first) that ``rule`` chooses."""
    k, value = _values(row)[rule]
    return int(np.argmax(value[:k]))


def summary(path: Path) -> None:
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    seeds = rows[0]["seeds"]
    print(f"{path}: {len(rows)} scenes, {len(rows[0]['wins'])} candidates searched each, {seeds} seeds each")
    base = np.array([r["wins"][pick("planner", r)] for r in rows]) / seeds
    for rule, text in RULES.items():
        got = np.array([r["wins"][pick(rule, r)] for r in rows]) / seeds
        diff = got - base
        boot = np.random.default_rng(0).choice(diff, (2000, len(diff))).mean(axis=1)
        print(f"  {rule:10s} {100 * got.mean():5.1f} %  paired {100 * diff.mean():+5.1f} "
              f"[{100 * np.percentile(boot, 2.5):+.1f}, {100 * np.percentile(boot, 97.5):+.1f}]  {text}")
    best = np.array([max(r["wins"]) for r in rows]) / seeds
    print(f"  ceiling    {100 * best.mean():5.1f} %  (the best of the searched candidates, per scene)")
    ranks = Counter(int(np.argmax(r["wins"])) for r in rows if max(r["wins"]) > 0)
    print("  rating rank of each scene's best candidate: "
          + ", ".join(f"#{k + 1} {n}" for k, n in sorted(ranks.items())))
    none = sum(max(r["wins"]) == 0 for r in rows)
    print(f"  scenes where no searched candidate wins any seed: {none} of {len(rows)}")
    if all("outcomes" in r for r in rows):
        held = np.array([held_out_best(r) for r in rows])
        print(f"  held-out ceiling {100 * held.mean():5.1f} %  (the candidate with the most wins on the "
              f"other {seeds - 1} seeds, scored on the one left out; ties by the planner's value): the"
              " ceiling without the maximum's optimism")
        mixed = sum(0 < r["wins"][pick("planner", r)] < seeds for r in rows)
        print(f"  scenes where the planner's pick both wins and loses across seeds: {mixed} of {len(rows)}")


def held_out_best(row: dict[str, Any]) -> float:
    """Leave-one-seed-out: for each seed, the candidate with the most wins on the other seeds (ties broken
    by the planner's value), scored on that seed; the mean over seeds."""
    out = np.asarray(row["outcomes"], float)  # (candidates, seeds)
    _, value = _values(row)["top12"]
    got = []
    for s in range(out.shape[1]):
        other = np.delete(out, s, axis=1).sum(axis=1)
        best = np.flatnonzero(other == other.max())
        got.append(out[best[np.argmax(value[best])], s])
    return float(np.mean(got))


def run(args: argparse.Namespace) -> None:
    import torch

    from tognet.evaluate.config import EvalConfig
    from tognet.jobs.models import load_model
    from tognet.jobs.scenes import reset_scene
    from tognet.objects import generate_set
    from tognet.planning import make_planner
    from tognet.sim import Simulator

    torch.set_num_threads(1)
    cfg = EvalConfig()
    model = load_model(str(args.model or Path("tognet/models") / f"{args.task}_search.pt"))
    old = {}
    if args.rescore:
        lines = args.rescore.read_text().splitlines()
        old = {(r["object_id"], r["scene_seed"]): r for r in map(json.loads, lines)}
    done = set()
    if args.out.exists():
        done = {(r["object_id"], r["scene_seed"]) for r in map(json.loads, args.out.read_text().splitlines())}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    objs = []
    for kind in args.kinds.split(","):
        folder = args.out.parent / f"objects-{kind}"
        objs += generate_set(kind, "train", args.objects, folder, start=args.start)
    stats: Counter[str] = Counter()
    for i, obj in enumerate(objs):
        sim = Simulator(cfg.sim, args.task, obj)
        planner = make_planner("TOG-Net+ActionSearch", sim.task, search_model=model, config=cfg.plan, sim=sim)
        for s in range(args.scenes):
            seed = 7919 * (args.start + i) + s
            if (obj.object_id, seed) in done or (args.rescore and (obj.object_id, seed) not in old):
                continue
            obs = reset_scene(sim, seed, stats)
            if obs is None:
                continue
            row = scene_rows(sim, planner, model, obs, args.top, args.seeds, np.random.default_rng(seed),
                             execute=not args.rescore)
            if args.rescore:  # the same candidates and actions: their trials are the old file's
                before = old[(obj.object_id, seed)]
                if not np.allclose(before["q_t"], row["q_t"]):
                    raise SystemExit(f"{obj.object_id} scene {seed}: other actions than in {args.rescore}")
                row["wins"] = before["wins"]
            row.update(object_id=obj.object_id, scene_seed=seed, task=args.task)
            with args.out.open("a") as f:
                f.write(json.dumps(row) + "\n")
        print(f"{args.task}: object {i + 1}/{len(objs)} done", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--task", choices=("sweeping", "hammering", "pulling"))
    ap.add_argument("--model", type=Path, help="the action-search model (default: the shipped one)")
    ap.add_argument("--kinds", default="primitive,complex", help="object kinds, comma-separated")
    ap.add_argument("--objects", type=int, default=30, help="objects per kind")
    ap.add_argument("--start", type=int, default=500, help="first training-split index (unseen: >= 150)")
    ap.add_argument("--scenes", type=int, default=2, help="scenes per object")
    ap.add_argument("--top", type=int, default=12, help="best-rated candidates searched and executed")
    ap.add_argument("--seeds", type=int, default=3, help="execution-noise seeds per candidate")
    ap.add_argument("--out", type=Path, help="JSON lines, one per scene (resumed)")
    ap.add_argument("--rescore", type=Path, help="add the scores to this finished file's scenes, no trials")
    ap.add_argument("--summary", type=Path, help="print the rules' success on a finished file")
    args = ap.parse_args()
    for given in (args.summary, args.rescore):
        if given is not None and not given.is_file():
            ap.error(f"{given}: no such file")
    if args.summary:
        summary(args.summary)
    elif args.task and args.out:
        run(args)
    else:
        ap.error("give --task and --out, or --summary")


if __name__ == "__main__":
    main()
