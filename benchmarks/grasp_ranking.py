"""Round 1's grasp ranking: the grasp-only model's Q_G against the antipodal score alone.

On unseen test objects (PG-Primitive and PG-Complex, split ``test``), for each scene the antipodal
candidates are ranked both ways; NMS keeps each ranking's modes; the top ``--top`` modes of each ranking
are executed in the grasp-only task (grasp and lift, no primitive). Prints S_G of each ranking's top
modes (what round 1 explores with) and the ROC-AUC of each score over every executed grasp.

    .venv/bin/python benchmarks/grasp_ranking.py --model runs/quick/grasping/model/best.pt [--objects 40]
        [--scenes 2] [--top 3]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from tognet.geometry import Grasp
from tognet.grasping import AntipodalConfig, CropConfig, prepare_depth, sample_antipodal
from tognet.jobs.models import load_model
from tognet.model.metrics import binary_metrics
from tognet.objects import generate_set
from tognet.policies.config import PolicyConfig
from tognet.policies.grasp import NMSGrasps
from tognet.policies.view import SceneView
from tognet.sim import SimConfig, SimulationError, Simulator


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", type=Path, required=True, help="The grasp-only model (best.pt).")
    ap.add_argument("--objects", type=int, default=40, help="Test objects per kind.")
    ap.add_argument("--scenes", type=int, default=2, help="Scenes per object.")
    ap.add_argument("--top", type=int, default=3, help="Top NMS modes of each ranking executed per scene.")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="tognet-ranking-"))
    model = load_model(str(args.model))
    crop = model.crop_config or CropConfig()
    rankers = {"antipodal": NMSGrasps(PolicyConfig()), "Q_G model": NMSGrasps(PolicyConfig(), model)}
    rows: dict[str, list[tuple[float, float, bool]]] = {k: [] for k in rankers}  # (antipodal, Q_G, S_G)
    rng = np.random.default_rng(args.seed)
    for kind in ("primitive", "complex"):
        for obj in generate_set(kind, "test", args.objects, work / kind):
            try:
                sim = Simulator(SimConfig(), "grasping", obj)
            except SimulationError as exc:
                print(f"skipped {obj.object_id}: {exc}")
                continue
            for s in range(args.scenes):
                try:
                    obs = sim.reset(1000 * s + args.seed)
                except SimulationError:
                    continue
                scene = prepare_depth(obs.depth, obs.camera)
                cands = sample_antipodal(scene, None, AntipodalConfig(axis_direction="both"), rng)
                if len(cands) == 0:
                    continue
                view = SceneView(scene, cands, None, crop)
                for name, ranker in rankers.items():
                    grasps, _ = ranker.modes(view)
                    top = grasps[: args.top]
                    crops, z = view.crops(top)
                    q_g = model.predict(crops, z).q_g
                    quality = _antipodal_quality(cands, top)
                    for g, qa, qg in zip(top, quality, q_g, strict=True):
                        res = sim.execute(Grasp.from_array(g), None, seed=0)
                        if res.valid:
                            rows[name].append((float(qa), float(qg), bool(res.grasp_success)))
    print(f"{args.objects} test objects per kind (PG-Primitive, PG-Complex), {args.scenes} scenes each, top "
          f"{args.top} NMS modes per ranking executed (grasp and lift)")
    for name, r in rows.items():
        arr = np.array(r)
        s_g = arr[:, 2].astype(bool)
        auc_a = binary_metrics(s_g, arr[:, 0]).get("auc")
        auc_q = binary_metrics(s_g, arr[:, 1]).get("auc")
        print(f"  ranked by {name:9s}: {len(arr)} grasps, S_G {s_g.mean():.1%}; over these grasps ROC-AUC of "
              f"the antipodal score {_f(auc_a)}, of Q_G {_f(auc_q)}")


def _antipodal_quality(cands: object, grasps: np.ndarray) -> np.ndarray:
    """The antipodal score of each grasp (it is one of the candidates, possibly turned by pi)."""
    g = cands.grasps  # type: ignore[attr-defined]
    d = np.linalg.norm(g[None, :, :3] - grasps[:, None, :3], axis=2)
    return cands.quality[np.argmin(d, axis=1)]  # type: ignore[attr-defined]


def _f(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.3f}"


if __name__ == "__main__":
    main()
