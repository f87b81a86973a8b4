"""Oracle+, the stronger bound (issue 34): simulator ground truth, never a method a robot could run.

The Oracle (:class:`tognet.planning.planners.OraclePlanner`) searches the hand-computed actions from the
antipodal candidates' NMS modes; a learned method sometimes succeeds where that search found nothing, so
"share of the Oracle" is measured against a bound that is beaten. Oracle+ widens what it tries, in stages
that share one budget (``BoundConfig.max_trials``), each pair on ``BoundConfig.seeds`` trials with
execution-noise seeds the evaluation never uses (1000 + k, as the Oracle's):

1. the Oracle's own plan (the Oracle row's, shared when both are evaluated), then every method's own
   plan (the methods a robot can run, given the same generator state as in the evaluation, so the very
   plan each of them executes), and the learned methods' next ``BoundConfig.alternatives`` grasps with
   their actions;
2. the Oracle's motion (its action search) from each of those grasps;
3. the Oracle's search over ``BoundConfig.grasps`` NMS modes;
4. around the best pair so far, when it is not sure: its action moved by ``BoundConfig.step`` along each
   of the action's position axes and by ``BoundConfig.turn`` in yaw, both ways (within the task's box).

A pair that wins on all ``BoundConfig.seeds`` trials is confirmed on ``BoundConfig.confirm`` more. Stage 1
is always tried whole; where several of its pairs won every trial, each gets ``BoundConfig.tiebreak`` more
(a plan that wins 7 of 7 can still be one that wins 3 in 4: the first one sure is not the most robust) and
the one that wins most is the plan. In the later stages the first pair that wins every trial ends the
search; otherwise the pair that won most is the plan. Its ``info["source"]`` says which stage found it.
The search's seeds are never the evaluation's: a method's plan that wins on the evaluation's seed and
loses on the search seeds (a plan at the edge of the execution noise) can still be one the bound does not
take; the evaluation counts such scenes (``beyond_bound``).
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
    """The best pair found so far, ordered by its successes on the search's trials."""

    wins: int = -1
    grasp: NDArray[np.float64] | None = None
    action: NDArray[np.float64] | None = None
    source: str = ""

    def offer(self, wins: int, grasp: NDArray[np.float64], action: Any, source: str) -> None:
        if wins > self.wins:
            self.wins, self.source = wins, source
            self.grasp, self.action = np.asarray(grasp, np.float64), np.asarray(action, np.float64)


class _Judge:
    """Every stage's pairs tried on one budget: ``seeds`` trials (stopping at a failure), then ``confirm``
    more for a pair that won them all; ``sure`` once a pair won every one."""

    def __init__(self, sim: Any, config: PlanConfig) -> None:
        self.search = OracleSearch(sim, config)
        self.seeds, self.confirm = config.bound.seeds, config.bound.confirm
        self.budget = config.bound.max_trials
        self.tiebreak = config.bound.tiebreak
        self.extra = 0  # trials run by searches of their own (the Oracle's)
        self.best = _Best()
        self.sure: list[tuple[NDArray[np.float64], NDArray[np.float64], str]] = []
        self.tiebreaks: list[int] = []

    @property
    def trials(self) -> int:
        return self.search.trials + self.extra

    @property
    def done(self) -> bool:
        return self.best.wins >= self.seeds + self.confirm or self.trials >= self.budget

    def left(self) -> int:
        return max(0, self.budget - self.trials)

    def _limit(self, seeds: int) -> None:
        """The search's trials per pair and the budget it has left."""
        self.search.config = dataclasses.replace(self.search.config, oracle=dataclasses.replace(
            self.search.config.oracle, seeds=seeds, max_trials=self.budget - self.extra))

    def _run(self, grasp: Grasp, action: Any, n: int, stop_at_failure: bool = True) -> int:
        self._limit(n)
        return self.search.try_pair(grasp, action, stop_at_failure)[0]

    def best_action(self, grasp: NDArray[np.float64]) -> tuple[float, int, NDArray[np.float64]] | None:
        """The Oracle's action search from ``grasp``, ``seeds`` trials per action, within the budget."""
        self._limit(self.seeds)
        return self.search.best_action(grasp)

    def judge(self, grasp: NDArray[np.float64], action: Any, source: str, prior: int | None = None) -> None:
        """Try (grasp, action), or take ``prior`` successes of an earlier search in ``seeds`` trials;
        confirm it where it won them all; offer it as the best."""
        g = Grasp.from_array(grasp)
        wins = self._run(g, action, self.seeds) if prior is None else prior
        if wins >= self.seeds:
            wins = self.seeds + self._run(g, action, self.confirm)
        if wins >= self.seeds + self.confirm:
            self.sure.append((np.asarray(grasp, np.float64), np.asarray(action, np.float64), source))
        self.best.offer(wins, grasp, action, source)

    def settle(self) -> None:
        """Where several pairs won every trial, ``tiebreak`` more trials each (all counted): the pair that
        wins most of them (the first on a tie) is the best."""
        if len(self.sure) < 2 or self.tiebreak == 0:
            return
        self.tiebreaks = [self._run(Grasp.from_array(g), a, self.tiebreak, stop_at_failure=False)
                          for g, a, _ in self.sure]
        grasp, action, source = self.sure[int(np.argmax(self.tiebreaks))]
        self.best.grasp, self.best.action, self.best.source = grasp, action, source


class BoundPlanner:
    """Oracle+ (see the module docstring). ``proposers``: the planners of the methods whose plans it tries
    (by method name, in the order they are tried); ``learned``: those of them whose next grasps it tries
    too; ``oracle``: the Oracle row's planner, whose plan is tried first. The simulator must hold the
    observation's scene, as for the Oracle."""

    name = "Oracle+"

    def __init__(self, sim: Any, config: PlanConfig, reach: ArmReach | None,
                 proposers: dict[str, PolicyPlanner], learned: tuple[str, ...] = (),
                 oracle: OraclePlanner | None = None) -> None:
        if sim.task is None:
            raise ValueError(f"Oracle+ plans for a task ({', '.join(TASK_NAMES)}), not for grasping only")
        self.sim = sim
        bc = config.bound
        wide = dataclasses.replace(config.oracle, grasps=bc.grasps, seeds=bc.seeds, max_trials=bc.max_trials)
        self.config = dataclasses.replace(config, oracle=wide)
        self.reach = reach
        self.proposers = proposers
        self.learned = learned
        self.oracle = oracle

    def plan(self, observation: Any, rng: np.random.Generator) -> Plan:
        """The best pair of the four stages for the simulator's current scene."""
        t0 = time.perf_counter()
        rng_start = copy.deepcopy(rng)
        judge = _Judge(self.sim, self.config)
        judge.search.check_scene(observation)
        grasps: list[tuple[str, NDArray[np.float64]]] = []
        for source, grasp, action in self.proposals(observation, rng_start, judge):
            grasps.append((source, grasp))
            if judge.left() > 0:
                judge.judge(grasp, action, source)
        if judge.done:
            judge.settle()
            return self._plan(judge, len(grasps), t0)
        for source, grasp in _distinct(grasps):
            found = judge.best_action(grasp)
            if found is not None:
                judge.judge(grasp, found[2], f"Oracle motion from {source}'s grasp", prior=found[1])
            if judge.done:
                return self._plan(judge, len(grasps), t0)
        return self._oracle_stage(observation, rng, judge, len(grasps), t0)

    __call__ = plan

    def proposals(self, observation: Any, rng_start: np.random.Generator, judge: _Judge | None = None
                  ) -> Iterator[Candidate]:
        """The Oracle's plan (its search's trials counted in ``judge``), then each proposer's plan (on a
        copy of the generator as the evaluation gave it) and the learned ones' alternatives after it;
        computed only when the search gets that far."""
        if self.oracle is not None:
            try:
                plan = self.oracle.plan(observation, copy.deepcopy(rng_start))
            except PlanningError:  # with an arm: nothing within its reach
                pass
            else:
                if judge is not None:
                    judge.extra += int(plan.info["search_trials"])
                if plan.info["found"]:
                    yield "Oracle", plan.grasp, plan.action
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

    def _oracle_stage(self, observation: Any, rng: np.random.Generator, judge: _Judge, proposed: int,
                      t0: float) -> Plan:
        """The wider Oracle search with the budget that is left; then the refinement of the best pair."""
        wide = dataclasses.replace(self.config.oracle, max_trials=max(1, judge.left()))
        try:
            found = OraclePlanner(self.sim, dataclasses.replace(self.config, oracle=wide), self.reach).plan(
                observation, rng)
        except PlanningError:
            if judge.best.grasp is None:
                raise
            return self._plan(judge, proposed, t0)
        judge.extra += int(found.info["search_trials"])
        if found.info["found"]:
            prior = int(found.scores["search_successes"])
            judge.judge(found.grasp, found.action, "Oracle search", prior=prior)
        best = judge.best
        if best.grasp is None:  # nothing held anywhere: the Oracle's fallback (its first grasp)
            best.grasp, best.action, best.source, best.wins = found.grasp, found.action, "Oracle fallback", 0
        elif best.wins > 0 and not judge.done:
            self._refine(judge)
        return self._plan(judge, proposed, t0, found.info.get("reach"))

    def _refine(self, judge: _Judge) -> None:
        """Stage 4: the best pair's action moved a step each way along each axis."""
        best = judge.best
        assert best.grasp is not None and best.action is not None
        task, bc = self.sim.task, self.config.bound
        grasp, start, source = best.grasp.copy(), best.action.copy(), best.source
        for axis, size in ((0, bc.step), (1, bc.step), (2, bc.step), (3, bc.turn)):
            for sign in (1.0, -1.0):
                action = start.copy()
                action[axis] += sign * size
                action = np.clip(action, task.action_low, task.action_high)
                if np.allclose(action, start):
                    continue
                judge.judge(grasp, action, f"{source}, refined")
                if judge.done:
                    return

    def _plan(self, judge: _Judge, proposed: int, t0: float, reach: Any = None) -> Plan:
        best = judge.best
        if best.grasp is None or best.action is None:
            raise PlanningError("Oracle+ found no grasp to try on the depth image")
        info: dict[str, Any] = {"search_trials": judge.trials, "source": best.source, "proposals": proposed,
                                "found": best.wins > 0, "tiebreak": judge.tiebreaks}
        if reach is not None:
            info["reach"] = reach
        timing = {"search": time.perf_counter() - t0, "total": time.perf_counter() - t0}
        wins = max(best.wins, 0)
        scores = {"choice": wins / (judge.seeds + judge.confirm), "search_successes": float(wins)}
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
