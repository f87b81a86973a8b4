"""Oracle+, the stronger bound (issue 34): simulator ground truth, never a method a robot could run.

The Oracle (:class:`tognet.planning.planners.OraclePlanner`) searches the hand-computed actions from the
antipodal candidates' NMS modes; a learned method sometimes succeeds where that search found nothing, so
"share of the Oracle" is measured against a bound that is beaten. Oracle+ widens what it tries, in stages
that share one budget (``BoundConfig.max_trials``), each pair on ``BoundConfig.seeds`` trials with
execution-noise seeds the evaluation never uses (1000 + k, as the Oracle's):

1. every method's own plan (the methods a robot can run, given the same generator state as in the
   evaluation, so the very plan each of them executes), and the learned methods' next
   ``BoundConfig.alternatives`` grasps with their actions;
2. the Oracle's motion (its action search) from each of those grasps;
3. the Oracle's own search over ``BoundConfig.grasps`` NMS modes;
4. around the best pair so far, when it is not sure: its action moved by ``BoundConfig.step`` along each
   of the action's position axes and by ``BoundConfig.turn`` in yaw, both ways (within the task's box).

A (grasp, action) that wins on every search seed ends the search; otherwise the pair that won most is the
plan. Its ``info["source"]`` says which stage found it. The search's seeds are never the evaluation's:
a method's plan that wins on the evaluation's seed and loses on the search seeds (a plan at the edge of
the execution noise) can still be one the bound does not take; the evaluation counts such scenes
(``beyond_bound``).
"""

from __future__ import annotations

import copy
import dataclasses
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Grasp
from tognet.planning.config import PlanConfig
from tognet.planning.plan import Plan, PlanningError
from tognet.planning.planners import OraclePlanner, OracleSearch, PolicyPlanner
from tognet.planning.reach import ArmReach
from tognet.tasks import TASK_NAMES

#: A candidate: (where it came from, grasp (4,), action (4,)).
Candidate = tuple[str, NDArray[np.float64], NDArray[np.float64]]


@dataclasses.dataclass
class _Best:
    """The best pair found so far: (share of search seeds won, wins) orders them."""

    share: float = -1.0
    wins: int = -1
    grasp: NDArray[np.float64] | None = None
    action: NDArray[np.float64] | None = None
    source: str = ""

    def offer(self, wins: int, seeds: int, grasp: NDArray[np.float64], action: Any, source: str) -> None:
        if (wins / seeds, wins) > (self.share, self.wins):
            self.share, self.wins, self.source = wins / seeds, wins, source
            self.grasp, self.action = np.asarray(grasp, np.float64), np.asarray(action, np.float64)


class BoundPlanner:
    """Oracle+ (see the module docstring). ``proposers``: the planners of the methods whose plans it tries
    (by method name, in the order they are tried); ``learned``: those of them whose next grasps it tries
    too. The simulator must hold the observation's scene, as for the Oracle."""

    name = "Oracle+"

    def __init__(self, sim: Any, config: PlanConfig, reach: ArmReach | None,
                 proposers: dict[str, PolicyPlanner], learned: tuple[str, ...] = ()) -> None:
        if sim.task is None:
            raise ValueError(f"Oracle+ plans for a task ({', '.join(TASK_NAMES)}), not for grasping only")
        self.sim = sim
        bc = config.bound
        wide = dataclasses.replace(config.oracle, grasps=bc.grasps, seeds=bc.seeds, max_trials=bc.max_trials)
        self.config = dataclasses.replace(config, oracle=wide)
        self.reach = reach
        self.proposers = proposers
        self.learned = learned

    def plan(self, observation: Any, rng: np.random.Generator) -> Plan:
        """The best pair of the three stages for the simulator's current scene."""
        t0 = time.perf_counter()
        rng_start = copy.deepcopy(rng)
        search = OracleSearch(self.sim, self.config)
        search.check_scene(observation)
        seeds = self.config.oracle.seeds
        best = _Best()
        grasps: list[tuple[str, NDArray[np.float64]]] = []
        for source, grasp, action in self.proposals(observation, rng_start):
            grasps.append((source, grasp))
            wins, _ = search.try_pair(Grasp.from_array(grasp), action)
            best.offer(wins, seeds, grasp, action, source)  # the first one is the fallback
            if best.wins == seeds or search.trials >= self.config.oracle.max_trials:
                return self._plan(best, search.trials, len(grasps), t0)
        for source, grasp in _distinct(grasps):
            found = search.best_action(grasp)
            if found is not None:
                best.offer(found[1], seeds, grasp, found[2], f"Oracle motion from {source}'s grasp")
            if best.wins == seeds or search.trials >= self.config.oracle.max_trials:
                return self._plan(best, search.trials, len(grasps), t0)
        return self._oracle_stage(observation, rng, best, search.trials, len(grasps), t0)

    __call__ = plan

    def proposals(self, observation: Any, rng_start: np.random.Generator) -> Iterator[Candidate]:
        """Each proposer's plan (on a copy of the generator as the evaluation gave it), the learned ones'
        alternatives after it; computed only when the search gets that far."""
        reference = getattr(observation, "reference", None)
        for name, planner in self.proposers.items():
            rng = copy.deepcopy(rng_start)
            try:
                view = planner.view(observation, rng, {})
                more = self.config.bound.alternatives if name in self.learned else 0
                plan = planner.plan_view(view, rng, reference=reference, alternatives=more)
            except PlanningError:  # no candidate, or none within the arm's reach: nothing to propose
                continue
            yield name, plan.grasp, plan.action
            for i, alt in enumerate(plan.alternatives):
                yield f"{name} #{i + 2}", alt.grasp, alt.action

    def _oracle_stage(self, observation: Any, rng: np.random.Generator, best: _Best, used: int,
                      proposed: int, t0: float) -> Plan:
        """The wider Oracle search with the budget that is left; its plan where it beats the best so far."""
        left = self.config.oracle.max_trials - used
        oracle_config = dataclasses.replace(self.config, oracle=dataclasses.replace(self.config.oracle,
                                                                                    max_trials=left))
        try:
            found = OraclePlanner(self.sim, oracle_config, self.reach).plan(observation, rng)
        except PlanningError:
            if best.grasp is None:
                raise
            return self._plan(best, used, proposed, t0)
        trials = used + int(found.info["search_trials"])
        if found.info["found"]:
            best.offer(int(found.scores["search_successes"]), self.config.oracle.seeds, found.grasp,
                       found.action, "Oracle search")
        if best.grasp is None:  # nothing held anywhere: the Oracle's fallback (its first grasp)
            best.grasp, best.action, best.source, best.share, best.wins = (found.grasp, found.action,
                                                                          "Oracle fallback", 0.0, 0)
        elif 0 < best.wins < self.config.oracle.seeds:
            trials += self._refine(best, trials)
        return self._plan(best, trials, proposed, t0, found.info.get("reach"))

    def _refine(self, best: _Best, used: int) -> int:
        """Stage 4: the best pair's action moved a step each way along each axis; the trials it took."""
        assert best.grasp is not None and best.action is not None
        search = OracleSearch(self.sim, self.config)
        search.trials = used
        search.seed += used  # new seeds' noise for new pairs, as the earlier stages' pairs had
        task, bc, seeds = self.sim.task, self.config.bound, self.config.oracle.seeds
        grasp, start, source = Grasp.from_array(best.grasp), best.action.copy(), best.source
        for axis, size in ((0, bc.step), (1, bc.step), (2, bc.step), (3, bc.turn)):
            for sign in (1.0, -1.0):
                action = start.copy()
                action[axis] += sign * size
                action = np.clip(action, task.action_low, task.action_high)
                if np.allclose(action, start):
                    continue
                wins, _ = search.try_pair(grasp, action)
                best.offer(wins, seeds, best.grasp, action, f"{source}, refined")
                if best.wins == seeds or search.trials >= self.config.oracle.max_trials:
                    return search.trials - used
        return search.trials - used

    def _plan(self, best: _Best, trials: int, proposed: int, t0: float, reach: Any = None) -> Plan:
        if best.grasp is None or best.action is None:
            raise PlanningError("Oracle+ found no grasp to try on the depth image")
        info: dict[str, Any] = {"search_trials": trials, "source": best.source, "proposals": proposed,
                                "found": best.wins > 0}
        if reach is not None:
            info["reach"] = reach
        timing = {"search": time.perf_counter() - t0, "total": time.perf_counter() - t0}
        scores = {"choice": max(best.share, 0.0), "search_successes": float(max(best.wins, 0))}
        return Plan(self.name, best.grasp, best.action, scores, timing, info)


def _distinct(grasps: list[tuple[str, NDArray[np.float64]]]) -> list[tuple[str, NDArray[np.float64]]]:
    """The first of each grasp that several proposals share (same to 0.1 mm and 1 mrad)."""
    seen: set[tuple[int, ...]] = set()
    out = []
    for source, g in grasps:
        key = tuple(int(v) for v in np.rint(np.asarray(g) * 1e4))
        if key not in seen:
            seen.add(key)
            out.append((source, g))
    return out
