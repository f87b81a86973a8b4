"""How the policies explore and search (saved with every collection, part of every planner's config)."""

from __future__ import annotations

from dataclasses import dataclass

from tognet.config import Config, doc
from tognet.grasping.cem import CEMConfig
from tognet.grasping.nms import NMSConfig


@dataclass(frozen=True)
class PolicyConfig(Config):
    """How the policies pick grasps and actions: collection's exploration (the paper's), the NMS and CEM
    settings the planners use too."""

    epsilon_grasp: float = doc(
        0.2, "epsilon_1: probability of an NMS grasp instead of the model's CEM grasp (rounds 2+; paper 0.2)."
    )
    epsilon_action: float = doc(
        0.2,
        "epsilon_2: probability of a uniformly random action instead of the policy's (rounds 2+; paper 0.2).",
    )
    action_noise: tuple[float, float, float, float] = doc(
        (0.02, 0.02, 0.01, 0.06),
        "Std-dev of the Gaussian policy's constant diagonal Sigma^(1/2) (a_x, a_y, a_z m; a_phi rad): the "
        "policy's action is the network's mean plus this noise, clipped to the task's action box. Smaller "
        "than the box (about a third of the random baseline's +-5 cm, +-pi/20 spread) so that greedy trials "
        "stay near what worked, large enough to keep exploring.",
    )
    expert_actions: float = doc(
        0.0,
        "Probability that an exploring action (round 1's uniform ones, the epsilon_2 ones later) is "
        "instead one of the simulator's hand-computed actions for that grasp (tognet.sim.oracle, one of its "
        "candidates at random): privileged exploration at training time only, not the paper's (0 = the "
        "paper). For tasks whose successful actions are a small target in the action box, so that uniform "
        "exploration finds too few successes to learn the policy from; labels still come from the trials.",
    )
    max_modes: int = doc(30, "NMS modes kept per scene at most (the paper's 10-30 distinct modes).")
    nms: NMSConfig = doc(factory=NMSConfig, text="Suppression radius of the exploration grasps.")
    cem: CEMConfig = doc(factory=CEMConfig, text="The cross-entropy method on the model's Q_T (rounds 2+).")
