"""How the policies explore and search (saved with every collection, part of every planner's config)."""

from __future__ import annotations

from dataclasses import dataclass

from tognet.config import Config, doc
from tognet.grasping.cem import CEMConfig
from tognet.grasping.nms import NMSConfig


@dataclass(frozen=True)
class ActionSearchConfig(Config):
    """The learned action search's sampling (:mod:`tognet.policies.action_search`)."""

    rate_samples: int = doc(
        48,
        "Actions scored per candidate grasp to rate it (its action mean included): enough to find the "
        "working region of the box for most grasps at a fraction of a millisecond per candidate.",
    )
    local_fraction: float = doc(
        0.5, "Share of the rating actions drawn around the candidate's action mean (the rest: the box).",
        ge=0, le=1,
    )
    local_std: tuple[float, float, float, float] = doc(
        (0.02, 0.02, 0.01, 0.08),
        "Std-dev of the rating draws around the action mean (a_x, a_y, a_z m; a_phi rad): about the "
        "collection policy's noise, where the data is densest.",
    )
    trust_region: float = doc(
        0.0,
        "0: actions are searched over the task's whole action box. > 0: within this many ``local_std`` of "
        "each candidate's own action mean (the policy head, fitted to successful actions), a region the "
        "data covers densely: a learned Q maximised far from its data finds its own errors.",
    )
    refine_grasps: int = doc(4, "Best-rated candidates whose action is then searched by CEM.", ge=0)
    iterations: int = doc(3, "CEM refits of the action (the paper's grasp CEM has 3).", ge=0)
    samples: int = doc(64, "Actions drawn per CEM iteration.", ge=1)
    elite_fraction: float = doc(0.25, "Share of the drawn actions kept to refit the Gaussian.", gt=0, le=1)
    min_std: tuple[float, float, float, float] = doc(
        (0.004, 0.004, 0.002, 0.02),
        "Floor of the CEM's std-dev per dimension, so the search does not collapse onto one draw.",
    )
    robust_samples: int = doc(
        8,
        "Perturbed copies of each of the CEM's final candidate actions over which their predicted success "
        "is averaged before the best is taken (0: no averaging). The best-scored action of a learned Q "
        "often sits on the edge of a failure region (the tool brought down on the can or the slot), where "
        "a small error of the model or of the execution tips it over; the average prefers the middle of a "
        "region that works.",
    )
    robust_std: tuple[float, float, float, float] = doc(
        (0.01, 0.01, 0.005, 0.05),
        "Std-dev of those perturbations (a_x, a_y, a_z m; a_phi rad): a little more than the execution "
        "noise on the start pose, the margin an action should keep from a failure region.",
    )
    robust_candidates: int = doc(
        16, "How many of the final CEM candidates (best first) are averaged so.", ge=1
    )
    pessimism: float = doc(
        1.0,
        "How many std-devs of the members' disagreement (ArchConfig.action_members) are taken off an "
        "action's predicted success when actions are ordered: a maximum over many actions otherwise picks "
        "those a model overrates where it has seen little. No effect with a single member.",
    )
    progress_weight: float = doc(
        0.1,
        "Weight of the predicted progress added to the predicted success when ordering actions: breaks "
        "ties where every action is unlikely to succeed, small enough not to trade success for it.",
    )


@dataclass(frozen=True)
class PolicyConfig(Config):
    """How the policies pick grasps and actions: collection's exploration (the paper's), the NMS and CEM
    settings the planners use too."""

    epsilon_grasp: float = doc(
        0.2,
        "epsilon_1: probability of an NMS grasp instead of the model's CEM grasp (rounds 2+; paper 0.2).",
        ge=0, le=1,
    )
    epsilon_action: float = doc(
        0.2,
        "epsilon_2: probability of a uniformly random action instead of the policy's (rounds 2+; paper 0.2).",
        ge=0, le=1,
    )
    action_noise: tuple[float, float, float, float] = doc(
        (0.02, 0.02, 0.01, 0.06),
        "Std-dev of the Gaussian policy's constant diagonal Sigma^(1/2) (a_x, a_y, a_z m; a_phi rad): the "
        "policy's action is the network's mean plus this noise, clipped to the task's action box. Smaller "
        "than the box (about a third of the random baseline's +-5 cm, +-pi/20 spread) so that greedy trials "
        "stay near what worked, large enough to keep exploring.",
        ge=0,
    )
    expert_actions: float = doc(
        0.0,
        "Probability that an exploring action (round 1's uniform ones, the epsilon_2 ones later) is "
        "instead one of the simulator's hand-computed actions for that grasp (tognet.sim.oracle, one of its "
        "candidates at random): privileged exploration at training time only, not the paper's (0 = the "
        "paper). For tasks whose successful actions are a small target in the action box, so that uniform "
        "exploration finds too few successes to learn the policy from; labels still come from the trials.",
        ge=0, le=1,
    )
    search_candidates: int = doc(
        8,
        "A 'search_candidates' round: how many of the action search's best candidates of each scene its "
        "greedy trials cycle through (each refined by CEM and executed with its searched action): the "
        "grasps the search ranks just below or above the one it picks, where its ranking within a scene is "
        "weakest.",
        ge=1, omit_default=True,
    )
    max_modes: int = doc(30, "NMS modes kept per scene at most (the paper's 10-30 distinct modes).", ge=1)
    nms: NMSConfig = doc(factory=NMSConfig, text="Suppression radius of the exploration grasps.")
    action_search: ActionSearchConfig = doc(
        factory=ActionSearchConfig,
        text="The learned action search (a model whose task stream sees the action): its greedy grasp and "
        "action in collection, and the TOG-Net+ActionSearch planner's.",
    )
    cem: CEMConfig = doc(factory=CEMConfig, text="The cross-entropy method on the model's Q_T (rounds 2+).")
