"""The two kinds of planner behind one signature: a grasp policy and an action policy on one observation
(:class:`PolicyPlanner`, every model method and baseline), and the Oracle's search in the simulator
(:class:`OraclePlanner`). Which method is which is declared in :mod:`tognet.planning.methods`.

Every planner samples the antipodal candidates first, so planners given generators in the same state see
the same candidates (the evaluation does this: paired comparisons). The Oracle reads the simulator's
ground truth and runs trials in it: an upper bound, not a method a robot could run.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Grasp
from tognet.planning.config import PlanConfig
from tognet.planning.plan import Plan, PlanningError
from tognet.policies.grasp import NMSGrasps
from tognet.policies.view import ActionPolicy, GraspPolicy, SceneView
from tognet.tasks import Task


def _scene_view(observation: Any, task: Task | None, config: PlanConfig, crop: Any,
                rng: np.random.Generator, timing: dict[str, float]) -> SceneView:
    """The policies' view of an observation: its depth image prepared and antipodal candidates sampled."""
    from tognet.grasping.antipodal import sample_antipodal
    from tognet.grasping.depth import prepare_depth

    t0 = time.perf_counter()
    scene = prepare_depth(observation.depth, observation.camera)
    t1 = time.perf_counter()
    cands = sample_antipodal(scene, None, config.antipodal, rng)
    timing["depth"], timing["candidates"] = t1 - t0, time.perf_counter() - t1
    if len(cands) == 0:
        raise PlanningError("no antipodal grasp candidate on the depth image")
    return SceneView(scene, cands, task, crop)


class PolicyPlanner:
    """A grasp policy and an action policy (:mod:`tognet.policies`) on one observation.

    ``score_model``: a model whose prediction at the chosen grasp is reported in ``Plan.scores``
    (``q_g``, ``q_t_given_g``, ``q_t``: how the task model rates every method's grasp); not counted in
    ``timing["total"]``, which is the method's own planning time."""

    def __init__(self, name: str, task: Task, grasp_policy: GraspPolicy, action_policy: ActionPolicy,
                 config: PlanConfig, crop: Any, score_model: Any = None) -> None:
        self.name = name
        self.task = task
        self.grasp_policy = grasp_policy
        self.action_policy = action_policy
        self.config = config
        self.crop = crop
        self.score_model = score_model

    def plan(self, observation: Any, rng: np.random.Generator) -> Plan:
        """One grasp and action for ``observation`` (PlanningError when there is no candidate)."""
        timing: dict[str, float] = {}
        t0 = time.perf_counter()
        view = _scene_view(observation, self.task, self.config, self.crop, rng, timing)
        t1 = time.perf_counter()
        pick = self.grasp_policy(view, 1, rng)
        t2 = time.perf_counter()
        acts = self.action_policy(view, pick.grasps, rng)
        t3 = time.perf_counter()
        timing.update(grasp=t2 - t1, action=t3 - t2, total=t3 - t0)
        scores = {"choice": float(pick.score[0])}
        if self.score_model is not None:  # diagnostics, not part of the method (nor of its time)
            crops, z = view.crops(pick.grasps)
            pred = self.score_model.predict(crops, z)
            scores.update(q_g=float(pred.q_g[0]), q_t_given_g=float(pred.q_t_given_g[0]),
                          q_t=float(pred.q_t[0]))
        return Plan(self.name, pick.grasps[0].astype(np.float64), acts.actions[0].astype(np.float64), scores,
                    timing, {"candidates": len(view.candidates), "grasp_source": int(pick.source[0]),
                             "action_source": int(acts.source[0])})

    __call__ = plan


class OraclePlanner:
    """The Oracle: the simulator's ground truth (settled object pose, the tool's pose in the hand, the
    props' layout) and trials run in the simulator itself. For each NMS mode of the antipodal candidates
    (best antipodal quality first), held either way round: a probe trial lifts the tool to see how it
    hangs in the hand, :mod:`tognet.sim.oracle` computes actions for that (sweeping: 5 start yaws, the
    tool's footprint centred on the cans, just behind them; hammering: the tool's farthest points meeting
    the peg), and each (grasp, action) runs on ``oracle.seeds`` execution-noise seeds the evaluation never
    uses (its trials use seed 0; the search uses 1000 + k). The first pair that succeeds on every search
    seed is the plan; otherwise the pair with the most successes once ``oracle.max_trials`` is spent.

    The simulator must hold the observation's scene (``sim.reset(observation.seed)`` last); every trial
    restores the settled scene, so the evaluation's own trial starts from the same state."""

    name = "Oracle"
    SEARCH_SEED = 1000

    def __init__(self, sim: Any, config: PlanConfig | None = None) -> None:
        if sim.task is None:
            raise ValueError("the Oracle plans for a task (sweeping or hammering), not for grasping only")
        self.sim = sim
        self.config = config or PlanConfig()

    def _actions(self, grasp: Grasp, in_hand: Any) -> list[NDArray[np.float64]]:
        from tognet.sim.oracle import task_actions

        return task_actions(self.sim, grasp, in_hand=in_hand)

    def plan(self, observation: Any, rng: np.random.Generator) -> Plan:
        """The best (grasp, action) the search finds for the simulator's current scene."""
        sim, oc = self.sim, self.config.oracle
        scene = sim.scene
        if scene is None or scene["seed"] != observation.seed or sim.obj.object_id != observation.object_id:
            raise ValueError("the Oracle's simulator does not hold the observation's scene: reset it first")
        timing: dict[str, float] = {}
        t0 = time.perf_counter()
        view = _scene_view(observation, sim.task, self.config, None, rng, timing)
        modes, _ = NMSGrasps(self.config.policy).modes(view)
        trials = 0
        seed = self.SEARCH_SEED
        best: tuple[float, int, NDArray[np.float64], NDArray[np.float64]] | None = None
        fallback = (modes[0].copy(), np.zeros(4))
        done = False
        for g in modes[: oc.grasps]:
            for flip in (0.0, np.pi):
                if done or trials >= oc.max_trials:
                    break
                grasp_arr = g.copy()
                grasp_arr[3] = np.mod(grasp_arr[3] + flip, 2 * np.pi)
                grasp = Grasp.from_array(grasp_arr)
                seed += 1
                trials += 1
                try:
                    probe = sim.execute(grasp, sim.task.nominal_action, seed)
                except ValueError:  # out of the gripper's reach
                    continue
                if not probe.grasp_success or "in_hand" not in probe.info:
                    continue
                for action in self._actions(grasp, probe.info["in_hand"]):
                    wins = tries = 0
                    for _ in range(oc.seeds):
                        if trials >= oc.max_trials:
                            break
                        seed += 1
                        trials += 1
                        try:
                            r = sim.execute(grasp, action, seed)
                        except ValueError:
                            break
                        if not r.valid:
                            continue
                        tries += 1
                        wins += int(r.task_success)
                        if not r.task_success:
                            break  # a pair that failed once cannot be the sure one: try the next
                    if tries:
                        key = (wins / oc.seeds, wins)
                        if best is None or key > (best[0], best[1]):
                            best = (key[0], wins, grasp_arr.copy(), np.asarray(action, dtype=np.float64))
                    if wins == oc.seeds:
                        done = True
                        break
        grasp_arr, action = (best[2], best[3]) if best is not None else fallback
        timing["search"] = time.perf_counter() - t0 - timing["depth"] - timing["candidates"]
        timing["total"] = time.perf_counter() - t0
        scores = {"choice": best[0] if best is not None else 0.0,
                  "search_successes": float(best[1]) if best is not None else 0.0}
        return Plan(self.name, grasp_arr, action, scores, timing,
                    {"search_trials": trials, "candidates": len(view.candidates), "found": best is not None})

    __call__ = plan
