"""Planners: ``plan(observation, rng) -> Plan`` for every method of the paper's evaluation and the Oracle.

    from tognet.planning import make_planner, METHODS
    planner = make_planner("TOG-Net", sim.task, grasp_model=g, task_model=t)
    plan = planner(sim.reset(seed), np.random.default_rng(0))
    result = sim.execute(plan.grasp_pose, plan.action, seed=0)

See :mod:`tognet.planning.methods` for what each method does (one row of a table each).

On a user's own depth image and camera (no simulator): :mod:`tognet.planning.user` (``tognet plan``)::

    plan = UserPlanner("hammering", "best.pt").plan("depth.png", "intrinsics.json")
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:
    from tognet.planning.config import BoundConfig, OracleConfig, PlanConfig
    from tognet.planning.methods import (
        METHOD_TABLE,
        METHODS,
        NEEDS,
        Method,
        MethodInputs,
        check_methods,
        get_method,
        make_planner,
    )
    from tognet.planning.plan import Plan, Planner, PlanningError
    from tognet.planning.planners import OraclePlanner, PolicyPlanner
    from tognet.planning.user import PlannedGrasp, UserPlan, UserPlanConfig, UserPlanner, plan_image

_WHERE = {
    "BoundConfig": "tognet.planning.config",
    "OracleConfig": "tognet.planning.config",
    "PlanConfig": "tognet.planning.config",
    "Plan": "tognet.planning.plan",
    "Planner": "tognet.planning.plan",
    "PlanningError": "tognet.planning.plan",
    "METHOD_TABLE": "tognet.planning.methods",
    "METHODS": "tognet.planning.methods",
    "NEEDS": "tognet.planning.methods",
    "Method": "tognet.planning.methods",
    "MethodInputs": "tognet.planning.methods",
    "check_methods": "tognet.planning.methods",
    "get_method": "tognet.planning.methods",
    "make_planner": "tognet.planning.methods",
    "OraclePlanner": "tognet.planning.planners",
    "PolicyPlanner": "tognet.planning.planners",
    "PlannedGrasp": "tognet.planning.user",
    "UserPlan": "tognet.planning.user",
    "UserPlanConfig": "tognet.planning.user",
    "UserPlanner": "tognet.planning.user",
    "plan_image": "tognet.planning.user",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE)

__all__ = [
    "BoundConfig",
    "METHOD_TABLE",
    "METHODS",
    "Method",
    "MethodInputs",
    "NEEDS",
    "OracleConfig",
    "OraclePlanner",
    "Plan",
    "PlanConfig",
    "Planner",
    "PlanningError",
    "PolicyPlanner",
    "check_methods",
    "get_method",
    "make_planner",
    "PlannedGrasp",
    "UserPlan",
    "UserPlanConfig",
    "UserPlanner",
    "plan_image",
]
