"""Grasp and action policies: the building blocks that collection, planning and evaluation share.

A policy is a small callable object of one of two shapes:

* a **grasp policy** ``policy(view, n, rng) -> GraspPick``: ``n`` world grasps (x, y, z, phi) for the
  observation in ``view``, with their source code and the score the policy chose by;
* an **action policy** ``policy(view, grasps, rng) -> ActionPick``: one action per grasp, with its source.

``view`` is a :class:`SceneView` (the prepared depth image, the antipodal candidates, the task and a cache
that policies on the same observation share) and ``rng`` the only source of randomness, so that the same
generator state gives the same picks. Policies are combined by other policies (the epsilon-greedy mix, the
expert-actions mix), never by the caller's branches: collection builds each round's pair from them
(:mod:`tognet.collect.jobs`), the planners each method's (:mod:`tognet.planning.methods`).

    view.py     SceneView, GraspPick, ActionPick, the GraspPolicy / ActionPolicy shapes, crop checks
    grasp.py    NMSGrasps (exploration modes), CEMGrasp (the model's grasp)
    action.py   uniform, the baselines' random, the Gaussian policy, the simulator's expert, none
    mix.py      EpsilonGreedyGrasps, EpsilonGreedyActions, ExpertMixActions: policies made of policies
    config.py   PolicyConfig (epsilons, the policy's noise, NMS and CEM settings)
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:
    from tognet.policies.action import (
        BaselineRandomActions,
        ExpertActions,
        NoActions,
        PolicyActions,
        UniformActions,
    )
    from tognet.policies.config import PolicyConfig
    from tognet.policies.grasp import CEMGrasp, NMSGrasps
    from tognet.policies.mix import EpsilonGreedyActions, EpsilonGreedyGrasps, ExpertMixActions, mix_picks
    from tognet.policies.view import (
        ActionPick,
        ActionPolicy,
        GraspPick,
        GraspPolicy,
        SceneView,
        check_predictor_crops,
    )

_WHERE = {
    "BaselineRandomActions": "tognet.policies.action",
    "ExpertActions": "tognet.policies.action",
    "NoActions": "tognet.policies.action",
    "PolicyActions": "tognet.policies.action",
    "UniformActions": "tognet.policies.action",
    "PolicyConfig": "tognet.policies.config",
    "CEMGrasp": "tognet.policies.grasp",
    "NMSGrasps": "tognet.policies.grasp",
    "EpsilonGreedyActions": "tognet.policies.mix",
    "EpsilonGreedyGrasps": "tognet.policies.mix",
    "ExpertMixActions": "tognet.policies.mix",
    "mix_picks": "tognet.policies.mix",
    "ActionPick": "tognet.policies.view",
    "ActionPolicy": "tognet.policies.view",
    "GraspPick": "tognet.policies.view",
    "GraspPolicy": "tognet.policies.view",
    "SceneView": "tognet.policies.view",
    "check_predictor_crops": "tognet.policies.view",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE)

__all__ = [
    "ActionPick",
    "ActionPolicy",
    "BaselineRandomActions",
    "CEMGrasp",
    "EpsilonGreedyActions",
    "EpsilonGreedyGrasps",
    "ExpertActions",
    "ExpertMixActions",
    "GraspPick",
    "GraspPolicy",
    "NMSGrasps",
    "NoActions",
    "PolicyActions",
    "PolicyConfig",
    "SceneView",
    "UniformActions",
    "check_predictor_crops",
    "mix_picks",
]
