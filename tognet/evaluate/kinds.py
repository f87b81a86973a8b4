"""What kind of row each method is in the evaluation's results and report, from the light-weight names of
:mod:`tognet.planning.method_names` (no model or simulator imports): ``baseline`` (the paper's),
``ours`` (TOG-Net, the learned action search and its twin check), ``oracle`` (the simulator's search, an
upper bound) and ``diagnostic`` (reads the simulator's ground truth for one half of the plan; never a
baseline, never "best").

The main comparison (the bar chart, the best method, the paired tables) covers the methods that are not
diagnostics (:func:`compared`); the diagnostics have a section of their own (where the gap to the Oracle
is) and are marked wherever else they appear (:data:`SIM_MARK`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Literal

from tognet.planning.method_names import DIAGNOSTIC_NAMES

Kind = Literal["baseline", "ours", "oracle", "diagnostic"]

REFERENCE = "TOG-Net"
ACTION_SEARCH = "TOG-Net+ActionSearch"
#: The action search's best plans tried in a world built from the depth image (tognet.planning.twin).
TWIN = "TOG-Net+Twin"
ORACLE = "Oracle"
#: The stronger bound (every method's plan tried, a wider search): what "share of the bound" is over.
BOUND = "Oracle+"
#: TOG-Net's grasp with the Oracle's motion: from TOG-Net's grasps, what a perfect motion achieves.
ORACLE_MOTION = "TOG-Net grasp + Oracle motion"
#: The Oracle's grasp with TOG-Net's motion: what TOG-Net's motion achieves from a perfect grasp.
ORACLE_GRASP = "Oracle grasp + TOG-Net motion"
#: The rows of the "where the gap is" decomposition, in the order they are drawn.
GAP_ROWS = (REFERENCE, ORACLE_MOTION, ORACLE_GRASP, ORACLE)
#: Appended to a diagnostic row's name in the report's tables: it uses the simulator's ground truth.
SIM_MARK = " †"
SIM_NOTE = ("†: a diagnostic row; it uses the simulator's ground truth for one half of the plan (not a "
            "method a robot could run, not a baseline, never counted as the best).")


def method_kind(name: str) -> Kind:
    """The kind of the method called ``name`` (an unknown name is a baseline)."""
    if name in (ORACLE, BOUND):
        return "oracle"
    if name in (REFERENCE, ACTION_SEARCH, TWIN):
        return "ours"
    if name in DIAGNOSTIC_NAMES:
        return "diagnostic"
    return "baseline"


def kinds_of(methods: Iterable[str], known: Mapping[str, str] | None = None) -> dict[str, str]:
    """``{method: kind}``: from ``known`` (a results.json's ``kinds``) where it has the method, else from
    :func:`method_kind`."""
    known = known or {}
    return {m: known.get(m) or method_kind(m) for m in methods}


def compared(methods: Iterable[str], known: Mapping[str, str] | None = None) -> list[str]:
    """The methods of the main comparison: every one that is not a diagnostic, in the given order."""
    methods = list(methods)
    kinds = kinds_of(methods, known)
    return [m for m in methods if kinds[m] != "diagnostic"]


def may_be_best(name: str, known: Mapping[str, str] | None = None) -> bool:
    """Whether a method competes for "best": a baseline or ours (not the Oracle, not a diagnostic)."""
    return kinds_of([name], known)[name] in ("baseline", "ours")


def label(name: str, known: Mapping[str, str] | None = None) -> str:
    """The method's name as a table shows it: a diagnostic's with :data:`SIM_MARK`."""
    return name + SIM_MARK if kinds_of([name], known)[name] == "diagnostic" else name


def scene_bound_name(methods: Iterable[str]) -> str:
    """The scene bound's row name (:func:`tognet.evaluate.harness.scene_bound`): the bound row it widens,
    "or any row"."""
    return f"{BOUND if BOUND in list(methods) else ORACLE} or any row"
