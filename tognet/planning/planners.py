"""The two kinds of planner behind one signature: a grasp policy and an action policy on one observation
(:class:`PolicyPlanner`, every model method and baseline), and the Oracle's search in the simulator
(:class:`OraclePlanner`). Which method is which is declared in :mod:`tognet.planning.methods`.

Every planner samples the antipodal candidates first, so planners given generators in the same state see
the same candidates (the evaluation does this: paired comparisons). The Oracle reads the simulator's
ground truth and runs trials in it: an upper bound, not a method a robot could run.
"""

from __future__ import annotations

import copy
import itertools
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.data.format import ACTION_SOURCES, GRASP_SOURCES
from tognet.geometry import Grasp
from tognet.grasping.nms import NMSConfig, angle_difference
from tognet.planning.config import PlanConfig
from tognet.planning.plan import Choice, Plan, PlanningError
from tognet.planning.reach import ArmReach, Option, Passed, ranked_grasps
from tognet.policies.grasp import NMSGrasps
from tognet.policies.view import ActionPick, ActionPolicy, GraspPick, GraspPolicy, SceneView
from tognet.tasks import TASK_NAMES, Task


def _scene_view(observation: Any, task: Task | None, config: PlanConfig, crop: Any,
                rng: np.random.Generator, timing: dict[str, float], reach: ArmReach | None = None
                ) -> SceneView:
    """The policies' view of an observation: its depth image prepared and antipodal candidates sampled;
    with an arm, those beyond its reach dropped (``view.cache["reach_dropped"]``, timed as ``reach``)."""
    from tognet.grasping.antipodal import sample_antipodal
    from tognet.grasping.depth import prepare_depth

    t0 = time.perf_counter()
    scene = prepare_depth(observation.depth, observation.camera)
    t1 = time.perf_counter()
    cands = sample_antipodal(scene, None, config.antipodal, rng)
    timing["depth"], timing["candidates"] = t1 - t0, time.perf_counter() - t1
    if len(cands) == 0:
        raise PlanningError("no antipodal grasp candidate on the depth image")
    if reach is None:
        return SceneView(scene, cands, task, crop)
    t2 = time.perf_counter()
    cands, dropped = reach.filter(cands)
    timing["reach"] = time.perf_counter() - t2
    return SceneView(scene, cands, task, crop, cache={"reach_dropped": dropped})


class PolicyPlanner:
    """A grasp policy and an action policy (:mod:`tognet.policies`) on one observation, in two halves:
    :meth:`view` (the observation's depth image prepared, its antipodal candidates sampled) and
    :meth:`plan_view` (the policies on a view). The evaluation calls both (:meth:`plan`); a user's image
    becomes its view elsewhere (:mod:`tognet.planning.user`: table frame, objects) and takes the second.

    ``models``: the method's models by what they are ("grasp", "task", "search"), which rate its plan
    (``Plan.own``: :meth:`rate`). ``score_model``: a model whose prediction at the chosen grasp is reported
    in ``Plan.scores`` (``q_g``, ``q_t_given_g``, ``q_t``: how the task model rates every method's grasp);
    not counted in ``timing["total"]``, which is the method's own planning time.

    ``reach``: with an arm (:class:`tognet.planning.reach.ArmReach`), the candidates beyond it are dropped
    before the policies see them, and the chosen grasp and action are checked through the whole trial,
    the grasp policy's next grasps taken in turn where the arm cannot (``Plan.info["reach"]``; timed as
    ``reach``)."""

    def __init__(self, name: str, task: Task, grasp_policy: GraspPolicy, action_policy: ActionPolicy,
                 config: PlanConfig, crop: Any, score_model: Any = None, reach: ArmReach | None = None,
                 models: dict[str, Any] | None = None) -> None:
        self.name = name
        self.task = task
        self.grasp_policy = grasp_policy
        self.action_policy = action_policy
        self.config = config
        self.crop = crop
        self.score_model = score_model
        self.reach = reach
        self.models = {k: m for k, m in (models or {}).items() if m is not None}

    def view(self, observation: Any, rng: np.random.Generator, timing: dict[str, float]) -> SceneView:
        """The policies' view of a simulator-like observation (depth, camera): see :func:`_scene_view`."""
        return _scene_view(observation, self.task, self.config, self.crop, rng, timing, self.reach)

    def plan(self, observation: Any, rng: np.random.Generator) -> Plan:
        """One grasp and action for ``observation`` (PlanningError when there is no candidate; its
        OutOfReach when none is within the arm's reach)."""
        timing: dict[str, float] = {}
        t0 = time.perf_counter()
        rng_start = copy.deepcopy(rng)
        view = self.view(observation, rng, timing)
        view.cache.update(observation=observation, rng_start=rng_start)  # for the diagnostic OracleGrasp
        return self.plan_view(view, rng, reference=getattr(observation, "reference", None), timing=timing,
                              t0=t0)

    def plan_view(self, view: SceneView, rng: np.random.Generator, *, reference: Any = None,
                  alternatives: int = 0, spacing: NMSConfig | None = None, reach: Any = None,
                  timing: dict[str, float] | None = None, t0: float | None = None) -> Plan:
        """The policies' grasp and action on ``view`` (its candidates already within the arm's reach, what
        was dropped in ``view.cache["reach_dropped"]``), rated by the method's models (``Plan.own``).

        ``reference``: the task's reference point, for the arm's check of the task's steps. ``alternatives``:
        also the method's next ``alternatives`` grasps, ranked its way, each at least ``spacing`` from those
        before (default 3 cm, either jaw orientation its own grasp), with their actions. ``reach``: the
        arm's filter to use instead of the planner's own (a user's, in the image's frame)."""
        timing = {} if timing is None else timing
        t0 = time.perf_counter() if t0 is None else t0
        reach = self.reach if reach is None else reach
        if reference is not None:  # for a grasp policy that tries its plans in the image's twin
            view.cache.setdefault("reference", np.asarray(reference, dtype=np.float64))
        t1 = time.perf_counter()
        pick = self.grasp_policy(view, 1, rng)
        t2 = time.perf_counter()
        acts = self.action_policy(view, pick.grasps, rng)
        t3 = time.perf_counter()
        timing.update(grasp=t2 - t1, action=t3 - t2)
        grasp, action = pick.grasps[0].astype(np.float64), acts.actions[0].astype(np.float64)
        first = (float(pick.score[0]), (int(pick.source[0]), int(acts.source[0])))
        options = self._options(view, Option(grasp, lambda: (action, first)), rng, alternatives, spacing,
                                reach)
        info: dict[str, Any] = {}
        if reach is not None:
            found = reach.choose(options, reference, view.cache["reach_dropped"], want=1 + alternatives)
            info["reach"], info["reach_choices"] = found[0].info(), found
            chosen = [(c.grasp, c.action, c.extra) for c in found]
        else:
            chosen = [(o.grasp, *o.action()) for o in itertools.islice(options, 1 + alternatives)]
        t4 = time.perf_counter()
        if reach is not None:
            timing["reach"] = timing.get("reach", 0.0) + t4 - t3
        elif alternatives:
            timing["alternatives"] = t4 - t3
        grasps = np.array([c[0] for c in chosen], dtype=np.float64)
        actions = np.array([c[1] for c in chosen], dtype=np.float64)
        own = self.rate(view, grasps, actions, [c[2][0] for c in chosen])
        t5 = time.perf_counter()
        timing.update(rate=t5 - t4, total=t5 - t0)
        (choice, sources) = chosen[0][2]
        if "twin" in view.cache:  # what the image's twin found (tognet.planning.twin)
            info["twin"] = view.cache["twin"]
        if alternatives and "ranked" in view.cache:
            info["ranked"] = view.cache["ranked"]
        return Plan(self.name, grasps[0], actions[0], self._scores(view, grasps[0], choice), timing,
                    {"candidates": len(view.candidates), "grasp_source": sources[0],
                     "action_source": sources[1], **info}, own[0],
                    tuple(Choice(g, a, o) for g, a, o in zip(grasps[1:], actions[1:], own[1:], strict=True)))

    def _scores(self, view: SceneView, grasp: NDArray[np.float64], choice: float) -> dict[str, float]:
        """``Plan.scores``: the policy's choice score, and the score model's rating of the grasp
        (diagnostics, not part of the method nor of its time)."""
        scores = {"choice": choice}
        if self.score_model is not None:
            crops, z = view.crops(grasp[None])
            pred = self.score_model.predict(crops, z)
            scores.update(q_g=float(pred.q_g[0]), q_t_given_g=float(pred.q_t_given_g[0]),
                          q_t=float(pred.q_t[0]))
        return scores

    def rate(self, view: SceneView, grasps: NDArray[np.float64], actions: NDArray[np.float64],
             choices: list[float]) -> list[dict[str, float]]:
        """The method's own scores of (grasp, action) pairs: ``score`` (the grasp policy's, ``choices``)
        and its parts from the method's models: the action-search model's Q_G and Q_T|G,a of the action
        (``q_t_given_ga``), else the task model's Q_G, Q_T|G and Q_T, else the grasp-only model's Q_G."""
        out: list[dict[str, float]] = [{"score": float(c)} for c in choices]
        if len(grasps) == 0 or not self.models:
            return out
        crops, z = view.crops(grasps)
        if "search" in self.models:
            model = self.models["search"]
            enc = model.encode(crops, z)
            q_tga = model.score_actions(enc, actions[:, None, :]).success[:, 0]
            parts = {"q_g": enc.q_g, "q_t_given_ga": q_tga, "q_t": enc.q_g * q_tga}
        elif "task" in self.models:
            pred = self.models["task"].predict(crops, z)
            parts = {"q_g": pred.q_g, "q_t_given_g": pred.q_t_given_g, "q_t": pred.q_t}
        else:
            parts = {"q_g": self.models["grasp"].predict(crops, z).q_g}
        for i, row in enumerate(out):
            row.update({k: float(v[i]) for k, v in parts.items()})
        return out

    def _options(self, view: SceneView, first: Option, rng: np.random.Generator, alternatives: int,
                 spacing: NMSConfig | None, reach: Any) -> Iterator[Option]:
        """The policy's choice, then (asked for only when it is out of reach or alternatives are wanted)
        its next grasps, each with the action policy's action for it; with ``alternatives``, each at least
        ``spacing`` from those before."""
        yield first
        if reach is None and not alternatives:
            return
        tries = reach.config.tries if reach is not None else 0
        ranked = ranked_grasps(self.grasp_policy, view, rng, tries + 1 + alternatives)
        view.cache["ranked"] = ranked  # what the method ranked, for pictures (tognet plan --rerun)
        keep = np.ones(len(ranked.grasps), dtype=bool)
        if alternatives:
            keep = _spaced(first.grasp, ranked.grasps, spacing or ALTERNATIVES)
        rows = np.flatnonzero(keep)
        if reach is None:  # the alternatives' actions in one batch
            rows = rows[:alternatives]
            if len(rows) == 0:
                return
            acts = self.action_policy(view, ranked.grasps[rows].astype(np.float64), rng)
            for j, i in enumerate(rows):
                extra = (float(ranked.score[i]), (int(ranked.source[i]), int(acts.source[j])))
                yield Option(ranked.grasps[i].astype(np.float64),
                             lambda a=acts.actions[j].astype(np.float64), e=extra: (a, e))
            return
        for i in rows:
            g, score, source = ranked.grasps[i], float(ranked.score[i]), int(ranked.source[i])

            def action(g: NDArray[np.float64] = g, score: float = score, source: int = source
                       ) -> tuple[NDArray[np.float64], Any]:
                acts = self.action_policy(view, g[None].astype(np.float64), rng)
                return acts.actions[0].astype(np.float64), (score, (source, int(acts.source[0])))

            yield Option(g.astype(np.float64), action)

    __call__ = plan


#: Alternatives' default spacing: 3 cm (and NMS's angle scale), either jaw orientation its own grasp (the
#: task cares which way round the tool is held).
ALTERNATIVES = NMSConfig(radius=0.03, symmetric_jaw=False)


def _spaced(first: NDArray[np.float64], grasps: NDArray[np.float64], config: NMSConfig) -> NDArray[np.bool_]:
    """Which of ``grasps`` (in order) are each at least ``config.radius`` (NMS's distance) from ``first``
    and from those kept before them: greedy, one pass per kept grasp."""
    period = np.pi if config.symmetric_jaw else 2 * np.pi
    alive = np.ones(len(grasps), dtype=bool)
    keep = np.zeros(len(grasps), dtype=bool)
    anchor: NDArray[np.float64] | None = np.asarray(first, dtype=np.float64)
    while anchor is not None:
        dp = grasps[:, :3] - anchor[:3]
        da = angle_difference(grasps[:, 3], anchor[3], period) * config.angle_scale
        alive &= np.einsum("ij,ij->i", dp, dp) + da * da >= config.radius**2
        left = np.flatnonzero(alive & ~keep)
        anchor = None
        if left.size:
            keep[left[0]] = True
            anchor = grasps[left[0]].astype(np.float64)
    return keep


class OracleSearch:
    """The Oracle's trials in the simulator (ground truth; never part of a method a robot could run).

    Every trial restores the settled scene, so a search leaves the simulator as it found it. Execution
    noise seeds count up from ``SEARCH_SEED`` (the evaluation's own trials use seed 0)."""

    SEARCH_SEED = 1000

    def __init__(self, sim: Any, config: PlanConfig) -> None:
        if sim.task is None:
            raise ValueError(f"the Oracle plans for a task ({', '.join(TASK_NAMES)}), not for grasping only")
        self.sim = sim
        self.config = config
        self.seed = self.SEARCH_SEED
        self.trials = 0

    def check_scene(self, observation: Any) -> None:
        """ValueError unless the simulator holds ``observation``'s settled scene."""
        scene, obj = self.sim.scene, self.sim.obj
        if scene is None or scene["seed"] != observation.seed or obj.object_id != observation.object_id:
            raise ValueError("the Oracle's simulator does not hold the observation's scene: reset it first")

    def _trial(self, grasp: Grasp, action: Any) -> Any:
        self.seed += 1
        self.trials += 1
        return self.sim.execute(grasp, action, self.seed)

    def try_pair(self, grasp: Grasp, action: Any, stop_at_failure: bool = True) -> tuple[int, int]:
        """(successes, valid trials) of one (grasp, action) on ``oracle.seeds`` search seeds, within the
        budget; stops at the first failure (a pair that failed once cannot be the sure one; unless
        ``stop_at_failure`` is false) and where the grasp or action is out of the gripper's reach."""
        oc = self.config.oracle
        wins = tries = 0
        for _ in range(oc.seeds):
            if self.trials >= oc.max_trials:
                break
            try:
                r = self._trial(grasp, action)
            except ValueError:
                break
            if not r.valid:
                continue
            tries += 1
            wins += int(r.task_success)
            if stop_at_failure and not r.task_success:
                break
        return wins, tries

    def best_action(self, grasp_arr: NDArray[np.float64], stop_at_sure: bool = True
                    ) -> tuple[float, int, NDArray[np.float64]] | None:
        """For one grasp: a probe trial lifts the tool to see how it hangs in the hand, then each of
        :func:`tognet.sim.oracle.task_actions` runs on ``oracle.seeds`` search seeds (a pair that fails
        once is dropped); (share of search seeds won, wins, action) of the best pair, or None when the
        grasp does not hold or is out of reach. Stops at the first pair that wins on every seed."""
        from tognet.sim.oracle import task_actions

        oc = self.config.oracle
        grasp = Grasp.from_array(grasp_arr)
        if self.trials >= oc.max_trials:
            return None
        try:
            probe = self._trial(grasp, self.sim.task.nominal_action)
        except ValueError:  # out of the gripper's reach
            return None
        if not probe.grasp_success or "in_hand" not in probe.info:
            return None
        best: tuple[float, int, NDArray[np.float64]] | None = None
        for action in task_actions(self.sim, grasp, in_hand=probe.info["in_hand"]):
            wins, tries = self.try_pair(grasp, action)
            if tries:
                key = (wins / oc.seeds, wins)
                if best is None or key > (best[0], best[1]):
                    best = (key[0], wins, np.asarray(action, dtype=np.float64))
            if stop_at_sure and wins == oc.seeds:
                break
        return best


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

    def __init__(self, sim: Any, config: PlanConfig | None = None, reach: ArmReach | None = None) -> None:
        if sim.task is None:
            raise ValueError(f"the Oracle plans for a task ({', '.join(TASK_NAMES)}), not for grasping only")
        self.sim = sim
        self.config = config or PlanConfig()
        self.reach = reach
        self._last: tuple[tuple[str, int, bytes], Plan] | None = None
        self._rng_after: dict[str, Any] = {}

    def plan(self, observation: Any, rng: np.random.Generator) -> Plan:
        """The best (grasp, action) the search finds for the simulator's current scene. The same
        observation with a generator in the same state gives the same plan; the last one is kept, so a
        second planner asking for it (the diagnostic "Oracle grasp + TOG-Net motion") costs no search."""
        key = (str(observation.object_id), int(observation.seed), repr(rng.bit_generator.state).encode())
        if self._last is not None and self._last[0] == key:
            rng.bit_generator.state = self._rng_after  # as if the search had run again
            return self._last[1]
        search = OracleSearch(self.sim, self.config)
        search.check_scene(observation)
        oc = self.config.oracle
        timing: dict[str, float] = {}
        t0 = time.perf_counter()
        view = _scene_view(observation, self.sim.task, self.config, None, rng, timing, self.reach)
        modes, _ = NMSGrasps(self.config.policy).modes(view)
        best: tuple[float, int, NDArray[np.float64], NDArray[np.float64]] | None = None
        fallback = (modes[0].copy(), np.zeros(4))
        done = False
        tried = 0
        passed: list[Passed] = []  # with an arm: the grasps out of its reach, never tried in the simulator
        reached: list[NDArray[np.float64]] = []
        for g in modes:
            if tried >= oc.grasps:
                break
            counted = False
            for flip in (0.0, np.pi):
                if done or search.trials >= oc.max_trials:
                    break
                grasp_arr = g.copy()
                grasp_arr[3] = np.mod(grasp_arr[3] + flip, 2 * np.pi)
                if self.reach is not None:
                    own = self.reach.own_steps(grasp_arr)
                    if own.stuck is not None:
                        passed.append(Passed(grasp_arr, own.stuck.what, own.stuck.reason))
                        continue
                    reached.append(grasp_arr)
                counted = True
                found = search.best_action(grasp_arr)
                if found is not None and (best is None or (found[0], found[1]) > (best[0], best[1])):
                    best = (found[0], found[1], grasp_arr.copy(), found[2])
                done = found is not None and found[1] == oc.seeds
            tried += int(counted or self.reach is None)
        info: dict[str, Any] = {}
        if self.reach is not None:
            if not reached:
                raise self.reach.out_of_reach(view.cache["reach_dropped"], passed)
            fallback = (reached[0].copy(), np.zeros(4))
            info["reach"] = self.reach.search_info(view.cache["reach_dropped"], passed, len(reached))
        grasp_arr, action = (best[2], best[3]) if best is not None else fallback
        timing["search"] = (time.perf_counter() - t0 - timing["depth"] - timing["candidates"]
                            - timing.get("reach", 0.0))
        timing["total"] = time.perf_counter() - t0
        scores = {"choice": best[0] if best is not None else 0.0,
                  "search_successes": float(best[1]) if best is not None else 0.0}
        plan = Plan(self.name, grasp_arr, action, scores, timing,
                    {"search_trials": search.trials, "candidates": len(view.candidates),
                     "found": best is not None, **info})
        self._last, self._rng_after = (key, plan), rng.bit_generator.state
        return plan

    __call__ = plan


class OracleGrasp:
    """Diagnostic grasp policy: the Oracle's grasp for the scene (its whole search, simulator ground
    truth), the same for every call. ``oracle`` is the planner (shared with the Oracle's own row, whose
    last plan it reuses); :class:`PolicyPlanner` keeps the observation and the generator as it was given
    (``view.cache["observation"]``, ``view.cache["rng_start"]``), so the search is the Oracle row's own."""

    def __init__(self, oracle: OraclePlanner) -> None:
        self.oracle = oracle

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick:
        plan = self.oracle.plan(view.cache["observation"], copy.deepcopy(view.cache["rng_start"]))
        return GraspPick(np.repeat(plan.grasp[None], n, axis=0), np.full(n, GRASP_SOURCES["given"], np.int8),
                         np.full(n, plan.scores.get("choice", 0.0), np.float32))


class OracleActions:
    """Diagnostic action policy: for each grasp, the Oracle's action search from it (a probe lift, the
    hand-computed actions tried in the simulator on search seeds; :meth:`OracleSearch.best_action`), its
    budget ``oracle.max_trials`` per grasp; the nominal action where the grasp does not hold."""

    def __init__(self, sim: Any, config: PlanConfig) -> None:
        self.sim = sim
        self.config = config

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        acts = np.zeros((len(grasps), 4))
        for i, g in enumerate(grasps):
            found = OracleSearch(self.sim, self.config).best_action(np.asarray(g, np.float64))
            acts[i] = found[2] if found is not None else self.sim.task.nominal_action
        return ActionPick(acts, np.full(len(grasps), ACTION_SOURCES["given"], np.int8))
