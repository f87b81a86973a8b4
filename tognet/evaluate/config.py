"""Settings of an evaluation (saved in its folder; a resume must use the same)."""

from __future__ import annotations

import json
from dataclasses import dataclass

from tognet.config import Config, doc
from tognet.io import short_digest
from tognet.planning.config import PlanConfig
from tognet.sim.config import SimConfig

#: Test-object categories: the paper's three and the object kind each is generated from.
CATEGORIES = {"pg-primitive": "primitive", "pg-complex": "complex", "realistic": "realistic"}


@dataclass(frozen=True)
class EvalConfig(Config):
    """How scenes are drawn and trials run; the methods, models and objects are given separately."""

    scenes_per_job: int = doc(
        2,
        "Scenes in one job (one test object; every method runs on each scene): the unit of work and of "
        "resumption. Few, so that a category's episodes spread over many objects.",
        ge=1,
    )
    seed: int = doc(0, "Root seed: scene seeds derive from (seed, task, category, job, scene).")
    trial_seed: int = doc(
        0,
        "Execution-noise seed of every evaluation trial: each method's trial on a scene runs with the same "
        "noise (common random numbers; the Oracle searches on other seeds).",
    )
    sim: SimConfig = doc(factory=SimConfig, text="The simulated world and every task's set-up.")
    plan: PlanConfig = doc(factory=PlanConfig, text="The planners' settings (candidates, CEM, Oracle).")

    def fingerprint(self) -> str:
        """A short hash of the config (stored with every job's results, to refuse mixing settings)."""
        return short_digest(json.dumps(self.to_dict(), sort_keys=True).encode())
