"""Planners: ``plan(observation, rng) -> Plan`` for every method of the paper's evaluation and the Oracle.

    from tognet.planning import make_planner, METHODS
    planner = make_planner("TOG-Net", sim.task, grasp_model=g, task_model=t)
    plan = planner(sim.reset(seed), np.random.default_rng(0))
    result = sim.execute(plan.grasp_pose, plan.action, seed=0)

See :mod:`tognet.planning.planners` for what each method does.

On a user's own depth image and camera (no simulator): :mod:`tognet.planning.user` (``tognet plan``)::

    plan = UserPlanner("hammering", "best.pt").plan("depth.png", "intrinsics.json")
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:
    from tognet.planning.config import OracleConfig, PlanConfig
    from tognet.planning.plan import Plan, Planner, PlanningError
    from tognet.planning.planners import (
        METHODS,
        NEEDS,
        OraclePlanner,
        PolicyPlanner,
        check_methods,
        make_planner,
    )
    from tognet.planning.user import PlannedGrasp, UserPlan, UserPlanConfig, UserPlanner, plan_image

_WHERE = {
    "OracleConfig": "tognet.planning.config",
    "PlanConfig": "tognet.planning.config",
    "Plan": "tognet.planning.plan",
    "Planner": "tognet.planning.plan",
    "PlanningError": "tognet.planning.plan",
    "METHODS": "tognet.planning.planners",
    "NEEDS": "tognet.planning.planners",
    "OraclePlanner": "tognet.planning.planners",
    "PolicyPlanner": "tognet.planning.planners",
    "check_methods": "tognet.planning.planners",
    "make_planner": "tognet.planning.planners",
    "PlannedGrasp": "tognet.planning.user",
    "UserPlan": "tognet.planning.user",
    "UserPlanConfig": "tognet.planning.user",
    "UserPlanner": "tognet.planning.user",
    "plan_image": "tognet.planning.user",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE)

__all__ = [
    "METHODS",
    "NEEDS",
    "OracleConfig",
    "OraclePlanner",
    "Plan",
    "PlanConfig",
    "Planner",
    "PlanningError",
    "PolicyPlanner",
    "check_methods",
    "make_planner",
    "PlannedGrasp",
    "UserPlan",
    "UserPlanConfig",
    "UserPlanner",
    "plan_image",
]
