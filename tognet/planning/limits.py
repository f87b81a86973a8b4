"""What a user's inputs to ``tognet plan`` may be: the depth image's scale judged from the table's distance,
and the task's reference point against the table the image shows and the arm's reach.

A depth file says nothing of its unit: 16-bit PNGs and integer arrays are read as millimetres, float arrays
as metres. A camera looking at a table sees it ``InputLimits.depth_range`` away; outside that the values are
in another unit, and the message names the one that puts the table nearest ``typical_depth`` within
``usual_depth`` (centimetres, 0.1 mm, ...) and how to convert. Inside the accepted range but outside the
usual one, with another unit giving a usual distance (a 0.1-mm PNG of a table 0.4 m away reads as 4 m), the
plan warns instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from tognet.config import Config, doc
from tognet.geometry import DepthImageError
from tognet.tasks import Task

if TYPE_CHECKING:
    from tognet.planning.reach import ArmReach

#: The units a depth file's values may be in, and their size in metres.
DEPTH_UNITS: dict[str, float] = {"metres": 1.0, "centimetres": 0.01, "millimetres": 0.001, "0.1 mm": 1e-4,
                                 "micrometres": 1e-6}


@dataclass(frozen=True)
class InputLimits(Config):
    """The plausible ranges of a user's inputs to the planner (see :mod:`tognet.planning.limits`)."""

    depth_range: tuple[float, float] = doc(
        (0.1, 5.0),
        "The table's distance from the camera (m; the median depth) a depth image is accepted with: outside "
        "it the values are refused as in another unit than the file is read in (16-bit PNGs and integer "
        "arrays: millimetres; float arrays: metres).", gt=0)
    usual_depth: tuple[float, float] = doc(
        (0.2, 2.5),
        "The table's usual distance from the camera (m): an accepted image outside it warns when another "
        "unit puts the table within it; the unit an error or warning names is the one that does.", gt=0)
    typical_depth: float = doc(
        0.8, "Of the units that put the table within ``usual_depth``, the one named puts it nearest this (m, "
        "in log-space).", gt=0)
    reference_distance: float = doc(
        2.0,
        "The task's reference point (``reference``, ``--reference``) may be at most this far (m), "
        "horizontally, from the part of the table the image shows (the tasks' reference points lie within "
        "0.4 m of the simulator camera's view).", ge=0)
    reference_below: float = doc(
        0.05, "The reference point may be at most this far (m) below the table top (the tasks' are 3.5-6 cm "
        "above it).", ge=0)
    reference_above: float = doc(
        0.5, "The reference point may be at most this high (m) above the table top.", ge=0)
    reference_reach: float = doc(
        0.05,
        "With an arm: the reference point is refused when every start pose the task's actions allow (a "
        "5-point grid on each axis of its action box, around the reference point plus its nominal offset) "
        "is more than this far (m) beyond the arm's outer envelope (which no reachable pose leaves).", ge=0)

    def __post_init__(self) -> None:
        for name in ("depth_range", "usual_depth"):
            lo, hi = getattr(self, name)
            if not lo < hi:
                raise ValueError(f"{name} must be (low, high) with low < high, got ({lo:g}, {hi:g})")


# --- the depth image's scale -------------------------------------------------------------------------------
def how_read(raw: NDArray, suffix: str | None) -> tuple[str, str]:
    """The unit ``raw`` (as stored, before conversion) is read in, and how that is said: ('millimetres',
    '16-bit PNGs are read as millimetres'). ``suffix``: the file's ('.png', '.npy', '.npz'), None for an
    array handed in."""
    integer = raw.dtype.kind in "iu"
    unit = "millimetres" if integer else "metres"
    if suffix == ".png":
        return unit, "16-bit PNGs are read as millimetres"
    kind = f"integer {suffix or ''}" if integer else f"float {suffix or ''}"
    return unit, f"{' '.join(kind.split())} arrays are read as {unit}"


def likely_unit(distance: float, read_as: str, limits: InputLimits) -> tuple[str, float] | None:
    """The unit other than ``read_as`` that puts a table seen ``distance`` m away (as read) within
    ``limits.usual_depth``, nearest ``typical_depth`` in log-space, and the distance it gives; None when
    none does."""
    lo, hi = limits.usual_depth
    best: tuple[float, str, float] | None = None
    for unit, size in DEPTH_UNITS.items():
        if unit == read_as:
            continue
        d = distance * size / DEPTH_UNITS[read_as]
        if lo <= d <= hi:
            score = abs(math.log(d / limits.typical_depth))
            if best is None or score < best[0]:
                best = (score, unit, d)
    return None if best is None else (best[1], best[2])


def conversion(unit: str, read_as: str) -> str:
    """How to turn values in ``unit`` into ``read_as``: 'divide by 10 to millimetres'."""
    ratio = DEPTH_UNITS[unit] / DEPTH_UNITS[read_as]
    if ratio > 1:
        return f"multiply by {round(ratio)} to {read_as}"
    return f"divide by {round(1 / ratio)} to {read_as}"


def _metres(d: float) -> str:
    return f"{d:.0f}" if d >= 100 else f"{d:.2f}" if d >= 1 else f"{d:.3f}"


def check_depth_scale(distance: float, read_as: str, how: str, where: str, limits: InputLimits) -> str | None:
    """DepthImageError (one line naming ``where``, the distance, the likely unit and the fix) when a table
    ``distance`` m from the camera, as read in ``read_as`` (said ``how``), is outside
    ``limits.depth_range``; a warning when it is outside ``usual_depth`` and another unit gives a usual
    distance; None otherwise."""
    guess = likely_unit(distance, read_as, limits)
    seen = f"{where}: the table is {_metres(distance)} m from the camera (the median depth; {how})"
    lo, hi = limits.depth_range
    if not lo <= distance <= hi:
        side = "nearer" if distance < lo else "farther"
        if guess is None:
            ulo, uhi = limits.usual_depth
            advice = f"no unit puts it {ulo:g}-{uhi:g} m away: is this a depth image?"
        else:
            advice = (f"the values look like {guess[0]} (the table would be {guess[1]:.2f} m away): "
                      f"{conversion(guess[0], read_as)}")
        raise DepthImageError(f"{seen}, {side} than a camera looking at a table ({lo:g}-{hi:g} m): {advice}")
    ulo, uhi = limits.usual_depth
    if guess is None or ulo <= distance <= uhi:
        return None
    side = "nearer" if distance < ulo else "farther"
    return (f"{seen}, {side} than usual ({ulo:g}-{uhi:g} m): if the values are {guess[0]} (the table "
            f"{guess[1]:.2f} m away), {conversion(guess[0], read_as)}")


# --- the reference point ---------------------------------------------------------------------------------
def footprint(points: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """(x min, x max, y min, y max) of the table-frame points (N, 3) the image shows (NaN rows skipped)."""
    xy = points[np.all(np.isfinite(points), axis=1), :2]
    return float(xy[:, 0].min()), float(xy[:, 0].max()), float(xy[:, 1].min()), float(xy[:, 1].max())


def check_reference(given: NDArray[np.float64], in_table: NDArray[np.float64],
                    box: tuple[float, float, float, float], frame: str, limits: InputLimits) -> None:
    """ValueError (one line naming the value, its frame and the distance) when the reference point
    ``given`` (in ``frame``), at ``in_table`` in the table frame, is farther than the limits from the
    image's view of the table (``box``, :func:`footprint`) or below or above the table top."""
    x0, x1, y0, y1 = box
    x, y, z = (float(v) for v in in_table)
    away = math.hypot(max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1))
    what = f"the reference point {' '.join(f'{v:g}' for v in given)} m ({frame} frame)"
    if away > limits.reference_distance:
        raise ValueError(f"{what} is {away:.2f} m from the table the image shows (its view spans x "
                         f"{x0:.2f}..{x1:.2f}, y {y0:.2f}..{y1:.2f} m in the table frame), more than "
                         f"{limits.reference_distance:g} m: metres, in the {frame} frame?")
    if z < -limits.reference_below:
        raise ValueError(f"{what} is {-z:.3f} m below the table top, more than {limits.reference_below:g} m: "
                         f"z = 0 is the table top, z up")
    if z > limits.reference_above:
        raise ValueError(f"{what} is {z:.3f} m above the table top, more than {limits.reference_above:g} m: "
                         f"z = 0 is the table top, z up")


def check_reference_reach(given: NDArray[np.float64], frame: str, task: Task, reach: ArmReach,
                          limits: InputLimits) -> None:
    """ValueError when every start pose the task's actions allow from the reference point ``given`` (in
    the frame of the arm's base) is more than ``limits.reference_reach`` beyond the arm's envelope
    (``reach``): no action reaches the task."""
    tc = task.config
    axes = [np.linspace(lo, hi, 5) for lo, hi in zip(task.action_low, task.action_high, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 4)
    start = np.asarray(given, dtype=np.float64) + np.asarray(tc.nominal_offset, dtype=np.float64)
    poses = np.column_stack([start + grid[:, :3], tc.nominal_yaw + grid[:, 3]])
    excess = float(reach.envelope.excess(poses).min())
    if excess > limits.reference_reach:
        raise ValueError(
            f"the reference point {' '.join(f'{v:g}' for v in given)} m ({frame} frame) puts every start "
            f"pose of the {task.name} task {excess:.2f} m or more beyond the {reach.name}'s reach "
            f"({reach.describe_base()}), more than {limits.reference_reach:g} m"
        )
