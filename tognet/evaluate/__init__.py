"""Evaluation: every method on the same unseen test scenes, statistics with intervals, and the report.

    from tognet.evaluate import run_evaluation
    results = run_evaluation("runs/eval", ["sweeping", "hammering"], "all", episodes=300)

``tognet evaluate`` is the command (:mod:`tognet.cli.evaluate`); :func:`run_demo` the small run
``make run`` shows.
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:
    from tognet.evaluate.config import CATEGORIES, EvalConfig
    from tognet.evaluate.demo import run_demo
    from tognet.evaluate.harness import EvalError, run_evaluation, summarise
    from tognet.evaluate.stats import newcombe_paired, paired_difference, wilson

_WHERE = {
    "CATEGORIES": "tognet.evaluate.config",
    "EvalConfig": "tognet.evaluate.config",
    "run_demo": "tognet.evaluate.demo",
    "EvalError": "tognet.evaluate.harness",
    "run_evaluation": "tognet.evaluate.harness",
    "summarise": "tognet.evaluate.harness",
    "newcombe_paired": "tognet.evaluate.stats",
    "paired_difference": "tognet.evaluate.stats",
    "wilson": "tognet.evaluate.stats",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE)

__all__ = [
    "CATEGORIES",
    "EvalConfig",
    "EvalError",
    "newcombe_paired",
    "paired_difference",
    "run_demo",
    "run_evaluation",
    "summarise",
    "wilson",
]
