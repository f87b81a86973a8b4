"""The evaluation's methods, each declared once: which models it needs, how its grasp and action policies
are built, and what kind of method it is.

===================  ===========================================  ==========================================
method               grasp                                        action
===================  ===========================================  ==========================================
Antipodal+Random     a random NMS mode of the antipodal           the baselines' random action (+-5 cm,
                     candidates ranked by antipodal quality,      +-pi/20 around the task's nominal start)
                     held either way round at random
Task_Agn+Random      CEM on the grasp-only model's Q_G            the baselines' random action
Task_Agn+Trained     CEM on the grasp-only model's Q_G            the task model's action mean at that grasp
Task_Ori+Random      CEM on the task model's Q_T = Q_T|G * Q_G    the baselines' random action
TOG-Net              CEM on the task model's Q_T                  the task model's action mean
TOG-Net+ActionSearch the best candidate by Q_G * max_a Q_T|G,a    CEM on Q_T|G,a at that grasp (the action-
                     (the action-conditioned model, beyond the    conditioned model; tognet.policies.
                     paper)                                       action_search)
TOG-Net+Twin         of the action search's 8 best (grasp,        the action search's for that grasp
                     action) pairs, the one that succeeds most
                     in a world built from the depth image alone
                     (tognet.planning.twin; beyond the paper)
Oracle               simulator search: NMS modes both ways        hand-computed from the tool's pose in the
                     round, each tried in the simulator           hand (tognet.sim.oracle), best found
Oracle+              every method's plan (and the learned ones'   theirs, then the Oracle's from their
                     next grasps), then a wider Oracle search,    grasps, then the wider search's; best
                     each tried in the simulator                  found (tognet.planning.bound)
===================  ===========================================  ==========================================

Two diagnostic rows split the gap between TOG-Net and the Oracle into its grasp and its motion (they read
the simulator's ground truth; never baselines, never deployable):

==============================  ==================================  ========================================
diagnostic                      grasp                               action
==============================  ==================================  ========================================
TOG-Net grasp + Oracle motion   TOG-Net's (CEM on Q_T)              the Oracle's action search from it
Oracle grasp + TOG-Net motion   the Oracle's (its whole search)     the task model's action mean at it
==============================  ==================================  ========================================

A method is a row of :data:`METHOD_TABLE` (a :class:`Method`): adding one is adding a row. Its kind says
what the evaluation may compare it with: ``baseline`` (the paper's), ``ours`` (TOG-Net), ``oracle`` (the
simulator's search, an upper bound) or ``diagnostic`` (uses the simulator's ground truth for one half of
the plan, to tell which half limits a method; neither a baseline nor deployable). Methods of the last two
kinds need the simulator.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from tognet.grasping.crops import resolve_crop
from tognet.planning.bound import BoundPlanner
from tognet.planning.config import PlanConfig
from tognet.planning.method_names import DIAGNOSTIC_NAMES, METHOD_NAMES
from tognet.planning.plan import Planner
from tognet.planning.planners import OracleActions, OracleGrasp, OraclePlanner, PolicyPlanner
from tognet.planning.reach import ArmReach, reach_of
from tognet.planning.twin import TwinGrasps
from tognet.policies.action import BaselineRandomActions, PolicyActions
from tognet.policies.action_search import ActionSearchActions, ActionSearchGrasps
from tognet.policies.grasp import CEMGrasp, NMSGrasps
from tognet.policies.view import ActionPolicy, GraspPolicy
from tognet.tasks import Task

#: The models a method can need: "grasp" (the grasp-only Q_G model), "task" (the task's TOG-Net),
#: "search" (the task's action-conditioned model, for the learned action search).
ModelName = Literal["grasp", "task", "search"]
#: What a method is (see the module docstring).
MethodKind = Literal["baseline", "ours", "oracle", "diagnostic"]


@dataclass(frozen=True)
class MethodInputs:
    """What a method's policies (or planner) are built from."""

    task: Task
    config: PlanConfig
    grasp_model: Any = None
    task_model: Any = None
    sim: Any = None
    search_model: Any = None
    reach: ArmReach | None = None
    sim_config: Any = None


@dataclass(frozen=True)
class Method:
    """One method: its name, kind and models, and either its grasp and action policies (planned by a
    :class:`PolicyPlanner`) or a planner of its own (``planner``: a joint search such as the Oracle's)."""

    name: str
    kind: MethodKind
    needs: tuple[ModelName, ...] = ()
    score: str = ""
    grasp: Callable[[MethodInputs], GraspPolicy] | None = None
    action: Callable[[MethodInputs], ActionPolicy] | None = None
    planner: Callable[[MethodInputs], Planner] | None = None

    def __post_init__(self) -> None:
        parts = (self.grasp is not None, self.action is not None)
        if parts != ((True, True) if self.planner is None else (False, False)):
            raise ValueError(f"method {self.name!r}: give a grasp and an action policy, or a planner")

    @property
    def baseline(self) -> bool:
        """One of the paper's baselines."""
        return self.kind == "baseline"

    @property
    def uses_sim(self) -> bool:
        """Reads the simulator's ground truth (the Oracle, the diagnostics): not a method a robot runs."""
        return self.kind in ("oracle", "diagnostic")


def _nms_antipodal(i: MethodInputs) -> GraspPolicy:
    return NMSGrasps(i.config.policy)


def _cem_q_g(i: MethodInputs) -> GraspPolicy:
    return CEMGrasp(i.config.policy, i.grasp_model, kind="grasp")


def _cem_q_t(i: MethodInputs) -> GraspPolicy:
    return CEMGrasp(i.config.policy, i.task_model, kind="task")


def _random_actions(i: MethodInputs) -> ActionPolicy:
    return BaselineRandomActions()


def _policy_mean(i: MethodInputs) -> ActionPolicy:
    return PolicyActions(i.task_model)


def _search_grasp(i: MethodInputs) -> GraspPolicy:
    return ActionSearchGrasps(i.search_model, i.config.policy.action_search)


def _twin_grasp(i: MethodInputs) -> GraspPolicy:
    return TwinGrasps(i.search_model, i.config.policy.action_search, i.config.twin, i.sim_config)


def _search_action(i: MethodInputs) -> ActionPolicy:
    return ActionSearchActions(i.search_model, i.config.policy.action_search)


_ORACLES: weakref.WeakKeyDictionary[Any, dict[tuple[str, int], OraclePlanner]] = weakref.WeakKeyDictionary()
_REACHES: weakref.WeakKeyDictionary[Any, dict[str, ArmReach | None]] = weakref.WeakKeyDictionary()


def oracle_for(sim: Any, config: PlanConfig, reach: ArmReach | None = None) -> OraclePlanner:
    """The Oracle's planner for ``sim`` and ``config`` (and the arm's reach it plans within): one per
    simulator, shared by the Oracle's row and the diagnostic that takes its grasp (which then reuses the
    Oracle's last plan instead of searching again)."""
    per_sim = _ORACLES.setdefault(sim, {})
    key = (repr(config), id(reach))  # frozen dataclasses all the way down: equal settings, equal text
    if key not in per_sim:
        # The planner holds the simulator by a weak proxy: a strong one from the cache's value would keep
        # its own key (and the whole simulator) alive, one per job, for as long as the worker runs.
        per_sim[key] = OraclePlanner(weakref.proxy(sim), config, reach)
    return per_sim[key]


def reach_for(sim: Any, config: PlanConfig) -> ArmReach | None:
    """The reach filter of the simulator's arm (:mod:`tognet.planning.reach`), one per simulator and
    settings, shared by every method planning on it; None for the floating gripper or with
    ``config.reach.enabled`` off."""
    per_sim = _REACHES.setdefault(sim, {})
    key = repr(config.reach)
    if key not in per_sim:
        per_sim[key] = reach_of(sim.config, sim.task, config.reach)
    return per_sim[key]


def _oracle(i: MethodInputs) -> Planner:
    return oracle_for(i.sim, i.config, i.reach)


def _bound(i: MethodInputs) -> Planner:
    """Oracle+: the Oracle row's planner (its plan tried first) and the planners of every method a robot
    can run (best first, the learned ones' alternatives tried too), with the models given."""
    proposers = {name: make_planner(name, i.task, grasp_model=i.grasp_model, task_model=i.task_model,
                                    config=i.config, search_model=i.search_model, reach=i.reach)
                 for name in BEST_FIRST}
    learned = tuple(m.name for m in METHOD_TABLE if m.kind == "ours")
    return BoundPlanner(i.sim, i.config, i.reach, proposers, learned,  # type: ignore[arg-type]
                        oracle_for(i.sim, i.config, i.reach))


def _oracle_grasp(i: MethodInputs) -> GraspPolicy:
    return OracleGrasp(oracle_for(i.sim, i.config, i.reach))


def _oracle_motion(i: MethodInputs) -> ActionPolicy:
    return OracleActions(i.sim, i.config)


#: Every method, in the order of the paper's figure (baselines, ours) and the Oracle last.
_Q_G = "Q_G (the grasp-only model)"
_Q_T = "Q_T = Q_T|G x Q_G (the task model)"
_SEARCH = "Q_G x Q_T|G,a of the searched action (the action-search model)"
_TWIN = "Q_G x Q_T|G,a of the searched action (the action-search model) of the pair chosen in the twin"
_SEEDS = "the share of the search's seeds it won (simulator)"
METHOD_TABLE: tuple[Method, ...] = (
    Method("Antipodal+Random", "baseline", (), "the antipodal quality of its NMS mode", grasp=_nms_antipodal,
           action=_random_actions),
    Method("Task_Agn+Random", "baseline", ("grasp",), _Q_G, grasp=_cem_q_g, action=_random_actions),
    Method("Task_Agn+Trained", "baseline", ("grasp", "task"), _Q_G, grasp=_cem_q_g, action=_policy_mean),
    Method("Task_Ori+Random", "baseline", ("task",), _Q_T, grasp=_cem_q_t, action=_random_actions),
    Method("TOG-Net", "ours", ("task",), _Q_T, grasp=_cem_q_t, action=_policy_mean),
    Method("TOG-Net+ActionSearch", "ours", ("search",), _SEARCH, grasp=_search_grasp, action=_search_action),
    Method("TOG-Net+Twin", "ours", ("search",), _TWIN, grasp=_twin_grasp, action=_search_action),
    Method("Oracle", "oracle", (), _SEEDS, planner=_oracle),
    Method("Oracle+", "oracle", ("grasp", "task", "search"), _SEEDS, planner=_bound),
    Method("TOG-Net grasp + Oracle motion", "diagnostic", ("task",), _Q_T, grasp=_cem_q_t,
           action=_oracle_motion),
    Method("Oracle grasp + TOG-Net motion", "diagnostic", ("task",), _SEEDS, grasp=_oracle_grasp,
           action=_policy_mean),
)
#: The method beyond the paper (the paper's own comparison reads without it).
ACTION_SEARCH = "TOG-Net+ActionSearch"
#: The methods' names, in the table's order.
METHODS: tuple[str, ...] = tuple(m.name for m in METHOD_TABLE)
if METHODS != METHOD_NAMES or DIAGNOSTIC_NAMES != tuple(m.name for m in METHOD_TABLE
                                                        if m.kind == "diagnostic"):
    raise ImportError("tognet.planning.method_names must list the method table's names in its order")
#: Which models each method needs.
NEEDS: dict[str, tuple[ModelName, ...]] = {m.name: m.needs for m in METHOD_TABLE}
#: The methods a robot can run (no simulator), best first: by the README evaluation's success on unseen
#: objects (every task); :func:`default_method` takes the first whose models are there.
BEST_FIRST: tuple[str, ...] = ("TOG-Net+ActionSearch", "TOG-Net+Twin", "TOG-Net", "Task_Agn+Trained",
                               "Task_Ori+Random", "Task_Agn+Random", "Antipodal+Random")
if sorted(BEST_FIRST) != sorted(m.name for m in METHOD_TABLE if not m.uses_sim):
    raise ImportError("BEST_FIRST must rank every method a robot can run")
#: What each model a method needs is, in words.
MODEL_WORDS: dict[str, str] = {"grasp": "the grasp-only model (Q_G)", "task": "a task's TOG-Net model",
                               "search": "a task's action-search model (task_head='action')"}


def robot_method(name: str) -> Method:
    """The row of a method a robot can run (ValueError for an unknown one, and for the Oracle and the
    diagnostic rows, which need the simulator)."""
    row = get_method(name)
    if row.uses_sim:
        raise ValueError(f"{row.name} needs the simulator's ground truth ({row.kind}): it cannot plan on a "
                         f"depth image; methods a robot can run: {', '.join(BEST_FIRST)}")
    return row


def default_method(has_models: Callable[[tuple[ModelName, ...]], bool]) -> str:
    """The best method a robot can run (:data:`BEST_FIRST`) whose models ``has_models(needs)`` says are
    there (e.g. shipped for the task)."""
    return next(name for name in BEST_FIRST if has_models(NEEDS[name]))


def get_method(name: str) -> Method:
    """The table's row of ``name`` (case-insensitive; ValueError for an unknown one)."""
    (known,) = check_methods([name])
    return next(m for m in METHOD_TABLE if m.name == known)


def check_methods(methods: list[str] | tuple[str, ...] | str) -> tuple[str, ...]:
    """``"all"``, a comma-separated string or a list, as known method names (ValueError otherwise)."""
    if isinstance(methods, str):
        methods = list(METHODS) if methods.strip() == "all" else [m.strip() for m in methods.split(",")]
    lower = {m.lower(): m for m in METHODS}
    out = []
    for m in methods:
        if m.lower() not in lower:
            raise ValueError(f"unknown method '{m}'; known: {', '.join(METHODS)} (or 'all')")
        if lower[m.lower()] not in out:
            out.append(lower[m.lower()])
    if not out:
        raise ValueError("no method given")
    return tuple(out)


def make_planner(method: str | Method, task: Task, *, grasp_model: Any = None, task_model: Any = None,
                 config: PlanConfig | None = None, sim: Any = None, search_model: Any = None,
                 reach: ArmReach | None = None, sim_config: Any = None) -> Planner:
    """The planner of ``method`` (a name of :data:`METHODS`, or a :class:`Method`) for ``task``.

    ``grasp_model`` / ``task_model`` / ``search_model``: predictors
    (:class:`tognet.model.predict.TOGNetPredictor`) of the grasp-only model, the task's TOG-Net and its
    action-conditioned model, as the method needs (:data:`NEEDS`); ``sim``: the simulator, for the
    methods that use it (the Oracle, the diagnostics). A task model given to a policy method also rates
    its chosen grasp (``Plan.scores``). The crops are ``config.crop`` or else the models' own (ValueError
    if they disagree).

    ``reach``: plan only what this arm reaches (:class:`tognet.planning.reach.ArmReach`, the same filter
    for every method); by default the simulator's arm when ``sim`` has one (``SimConfig.robot`` not
    floating) and ``config.reach.enabled`` is on. The floating gripper's plans never pass through it.
    ``sim_config``: the settings of the twin's world (TOG-Net+Twin: the robot's own hand, physics and
    task settings, never a scene); by default the simulator's, else the defaults."""
    row = method if isinstance(method, Method) else get_method(method)
    config = config or PlanConfig()
    if row.uses_sim and sim is None:
        raise ValueError(f"{row.name} needs the simulator (sim=...)")
    if reach is None and sim is not None:
        reach = reach_for(sim, config)
    models = {"grasp": grasp_model, "task": task_model, "search": search_model}
    what = {"grasp": "the grasp-only model", "task": f"the {task.name} model",
            "search": f"the {task.name} action-search model (a model trained with task_head='action')"}
    for need in row.needs:
        if models[need] is None:
            raise ValueError(f"{row.name} needs {what[need]}")
    if search_model is not None and "search" in row.needs:
        if not getattr(search_model, "action_conditioned", False):
            raise ValueError(f"{row.name}: {what['search']} is needed; this one's task stream does not see "
                             "the action")
        if getattr(search_model, "task", task.name) not in (None, task.name):
            raise ValueError(f"the action-search model was trained for {search_model.task}, not {task.name}")
    if sim_config is None and "TOG-Net+Twin" == row.name:  # the twin's world: the simulator's settings
        from tognet.sim.config import SimConfig

        sim_config = sim.config if sim is not None else SimConfig()
    inputs = MethodInputs(task, config, grasp_model, task_model, sim, search_model, reach, sim_config)
    if row.planner is not None:  # a planner of its own (the Oracle's search: no model, no crops)
        return row.planner(inputs)
    assert row.grasp is not None and row.action is not None
    if task_model is not None and getattr(task_model, "task", task.name) not in (None, task.name):
        raise ValueError(f"the task model was trained for {task_model.task}, not {task.name}")
    used = [models[n] for n in row.needs] + ([task_model] if task_model is not None else [])
    try:
        crop = resolve_crop(used, config.crop)
    except ValueError as exc:
        raise ValueError(f"{row.name}'s model: {exc}") from None
    return PolicyPlanner(row.name, task, row.grasp(inputs), row.action(inputs), config, crop,
                         score_model=task_model, reach=reach, models={n: models[n] for n in row.needs})
