"""What stands on the table in a user's depth image: regions that rise above the fitted plane, judged on
whether a gripper could pick them up, and the one a plan is for."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tognet.config import Config, doc
from tognet.errors import TognetError
from tognet.geometry import CameraIntrinsics
from tognet.planning.table import TablePlane
from tognet.planning.touching import (
    axis_offset,
    cut_point,
    elongation,
    enclosed_floor,
    find_pinch,
    find_valley,
    neck_point,
    neck_seeds,
    smoothed_heights,
    solidity,
    split_labels,
)


class NoObjectError(TognetError):
    """Nothing stands on the table."""


@dataclass(frozen=True)
class SegmentConfig(Config):
    """What counts as an object a gripper can pick up off the table. Objects are made of measured pixels
    only: a hole (no reading) never makes an object nor adds to one's area or height."""

    min_height: float = doc(
        0.005,
        "A measured pixel is part of an object when its surface is this much (m) above the table plane (the "
        "antipodal sampler's ``min_object_height``), or ``noise_sigmas`` times the range noise at its "
        "depth if that is more.",
    )
    noise_sigmas: float = doc(
        3.0,
        "The height threshold is at least this many times the range noise at the pixel's depth (measured on "
        "the table's own pixels, growing with depth squared, see :func:`table_noise`): a far, noisy table "
        "does not rise into objects.",
    )
    min_area: float = doc(
        4e-4,
        "Regions whose measured pixels cover less than this (m^2, seen from above) are noise: not listed.",
    )
    max_area: float = doc(
        0.12,
        "An object covering more than this (m^2; 1,200 cm^2, a 60 x 20 cm board) is not something the "
        "gripper picks up: another surface (a shelf, a box), or the table's plane fitted wrong.",
    )
    max_height: float = doc(
        0.3,
        "An object whose top is more than this (m) above the table is not a tool lying on it: a wall, a "
        "person, or the table itself seen above the floor.",
    )
    min_measured: float = doc(
        0.5,
        "Share of an object's region (its measured pixels and the holes bridged into it, see ``bridge``) "
        "that must have been measured; less is mostly guessed.",
    )
    bridge: int = doc(
        2,
        "Holes within this many pixels of an object's measured pixels join them into one region, so that a "
        "dropout across a handle does not cut the tool in two; they never add to its area or height.",
    )
    core: int = doc(
        1,
        "A region must hold a pixel whose neighbours within this many pixels are all measured and above "
        "the table (a core): range noise alone almost never makes one, so the speckles of a far, noisy "
        "table are not objects (a 3 x 3 core: 1e-7 per pixel where noise lifts 16 % of them). 0: off.",
    )
    wall_ratio: float = doc(
        0.25,
        "A region touching the image border whose footprint on the table is thinner than this fraction of "
        "its rise is a vertical surface (a wall, a cupboard's side), not an object.",
    )
    centre_zone: float = doc(
        1 / 6,
        "Of the objects that look like something to pick up, the plan is made on the largest of those that "
        "reach within this fraction of the image's smaller side of its centre (the camera is taken to be "
        "aimed at the tool: a can or a block beside it is passed over), or else on the one nearest the "
        "centre.",
    )
    mask_margin: int = doc(
        2, "Pixels around an object not planned on that are replaced by the table too (its edge, its shadow)."
    )
    touching: bool = doc(
        True,
        "Look in every region that looks like something to pick up for two objects touching "
        "(:mod:`tognet.planning.touching`): split it in two where its heights show a valley between two "
        "tops, warn where its footprint pinches between two parts. False: every region is one object.",
    )
    part_area: float = doc(
        20e-4,
        "Each of two objects touching covers at least this (m^2, 20 cm^2, seen from above); smaller parts "
        "are a tool's own bumps.", gt=0,
    )
    valley_depth: float = doc(
        0.010,
        "A region is split in two when the lowest way between two parts' tops goes at least this far (m) "
        "below the lower top (and down to ``valley_ratio`` of its height).", ge=0,
    )
    valley_ratio: float = doc(
        0.6,
        "A region is split in two when the lowest way between two parts' tops goes down to this fraction "
        "of the lower top's height above the table (and ``valley_depth`` below it): two tools' sides curve "
        "down to where they touch, one tool's parts are joined high.", gt=0, le=1,
    )
    neck_ratio: float = doc(
        0.4,
        "A region whose footprint narrows between two parts to at most this fraction of both parts' "
        "widths (the widest disc each holds) is reported as maybe two objects touching, not split (where a "
        "thin handle meets a big head, the narrowest bit is the handle itself).", gt=0, le=1,
    )
    handle_solidity: float = doc(
        0.7,
        "A part of a region that fills at least this share of its convex hull, is ``handle_elongation`` "
        "times longer than wide and whose long axis runs (within ``handle_offset``) through where it meets "
        "the rest is a handle running into its tool's head (a hammer's, a trowel's grip, a roller's): such "
        "a region is one tool, never split nor reported.", gt=0, le=1,
    )
    handle_elongation: float = doc(
        1.5, "A handle is at least this many times longer than wide (see ``handle_solidity``).", ge=1,
    )
    handle_offset: float = doc(
        0.35,
        "A handle's long axis passes at most this share of its width from where it meets the rest of its "
        "tool (0: through the middle of the joint; 0.5: past its side, as where one tool's side touches "
        "another's end).", ge=0,
    )


@dataclass(frozen=True, eq=False)
class TableObject:
    """One region standing on the table: its measured pixels (``mask``), their area (m^2, seen from above),
    its top (m above the table: the 99th percentile of its heights), centre (table frame, z = 0) and centre
    pixel (u, v), the share of its region measured, its pixel box (u0, v0, u1, v1; exclusive ends), whether
    it touches the image border, ``rejected``: why it does not look like something to pick up (None: it
    does), ``index``: its place in :func:`segment_objects`' list, ``centre_distance``: pixels from the
    image's centre to its nearest pixel and ``central``: whether that is within ``centre_zone``;
    ``touching``: why it may be two objects touching (None: no sign of it), and ``split``: whether it is
    one of two objects split from one region (``touching`` then says why and names the other)."""

    mask: NDArray[np.bool_]
    area: float
    height: float
    centre: NDArray[np.float64]
    touches_border: bool
    measured: float = 1.0
    pixel: tuple[float, float] = (0.0, 0.0)
    box: tuple[int, int, int, int] = (0, 0, 0, 0)
    rejected: str | None = None
    index: int = 0
    centre_distance: float = 0.0
    central: bool = True
    touching: str | None = None
    split: bool = False

    @property
    def qualifies(self) -> bool:
        """It looks like something a gripper can pick up."""
        return self.rejected is None

    def summary(self) -> str:
        """One line: '#i: A cm^2, H mm high, at pixel (u, v)' (and why it was rejected)."""
        text = (f"#{self.index}: {self.area * 1e4:.0f} cm^2, {1000 * self.height:.0f} mm high, at pixel "
                f"({self.pixel[0]:.0f}, {self.pixel[1]:.0f})")
        return text if self.rejected is None else f"{text}, {self.rejected}"

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary (no mask)."""
        return {"index": self.index, "area_cm2": round(self.area * 1e4, 1), "height_m": round(self.height, 4),
                "centre_table_m": [round(float(v), 4) for v in self.centre],
                "pixel": [round(float(v), 1) for v in self.pixel], "box_px": list(self.box),
                "pixels": int(self.mask.sum()), "measured_share": round(self.measured, 3),
                "touches_image_border": self.touches_border,
                "centre_distance_px": round(self.centre_distance, 1), "qualifies": self.qualifies,
                "rejected_because": self.rejected, "touching": self.touching, "split": self.split}


def _rejection(cfg: SegmentConfig, area: float, top: float, measured: float, thickness: float, rise: float,
               border: bool) -> str | None:
    """Why a region does not look like something a gripper picks up off the table (None: it does)."""
    if measured < cfg.min_measured:
        return (f"mostly unmeasured ({100 * measured:.0f} % of it measured, at least "
                f"{100 * cfg.min_measured:.0f} % needed)")
    if border and thickness < cfg.wall_ratio * rise:
        return (f"a vertical surface at the image's edge ({1000 * thickness:.0f} mm thick seen from above, "
                f"rising {1000 * rise:.0f} mm): a wall?")
    if top > cfg.max_height:
        return (f"too tall for a tool lying on the table (at most {1000 * cfg.max_height:.0f} mm): a wall, a "
                "person, or the table seen above the floor?")
    if area > cfg.max_area:
        return (f"larger than anything the gripper picks up (at most {1e4 * cfg.max_area:.0f} cm^2): another "
                "surface, or the table not flat?")
    return None


def table_noise(height: NDArray[np.float32], depth: NDArray[np.float32], band: float = 0.01,
                samples: int = 4000) -> tuple[float, float]:
    """(sigma, depth) of the range noise the table's own pixels show: the robust spread (1.4826 x the median
    absolute deviation) of the heights within ``band`` of the table, on a grid of about ``samples`` of
    them, and their median depth. (0, 1) when too few are seen."""
    step = max(1, int(math.sqrt(height.size / max(samples, 1))))
    h, d = height[::step, ::step].ravel(), depth[::step, ::step].ravel()
    with np.errstate(invalid="ignore"):
        on = np.abs(h) < band
    if np.count_nonzero(on) < 50:
        return 0.0, 1.0
    h, d = h[on].astype(np.float64), d[on].astype(np.float64)
    return 1.4826 * float(np.median(np.abs(h - np.median(h)))), float(np.median(d))


def segment_objects(height: NDArray[np.float32], depth: NDArray[np.float32], intrinsics: CameraIntrinsics,
                    table_from_camera: NDArray[np.float64], config: SegmentConfig | None = None,
                    noise: tuple[float, float] = (0.0, 1.0)) -> list[TableObject]:
    """Every region standing on the table, from measured pixels only, in the order a plan would choose
    them (``index``: the place in this list): first those that look like something a gripper picks up,
    those reaching within ``centre_zone`` of the image's centre largest first, then the others nearest the
    centre first; then the rest, largest first.

    ``height``: per pixel, m above the table, NaN where nothing was measured; ``depth``: the measured depth
    (NaN holes); ``table_from_camera``: the table frame; ``noise``: the range noise (sigma, at depth) of
    :func:`table_noise`. A region is 8-connected measured pixels more than ``min_height`` (or
    ``noise_sigmas`` x the noise at their depth) above the table, joined across holes at most ``bridge``
    pixels from them; its area sums its measured pixels' footprints on the table (depth^2 / (fx fy
    cos(incidence))), and regions under ``min_area`` or without a ``core`` (noise) are left out. A region
    is rejected (``TableObject.rejected`` says why) when mostly unmeasured, a vertical surface at the
    image's edge (a wall), taller than ``max_height`` or larger than ``max_area``."""
    cfg = config or SegmentConfig()
    k = intrinsics
    measured = np.isfinite(depth)
    sigma, at = noise
    with np.errstate(invalid="ignore"):
        if sigma > 0 and cfg.noise_sigmas * sigma * (np.nanmax(depth) / at) ** 2 > cfg.min_height:
            scale = np.float32(cfg.noise_sigmas * sigma / at**2)
            above = height > np.maximum(np.float32(cfg.min_height), scale * depth * depth)
        else:
            above = height > np.float32(cfg.min_height)
    rows_in, cols_in = np.flatnonzero(above.any(axis=1)), np.flatnonzero(above.any(axis=0))
    if rows_in.size == 0:
        return []
    # Everything below works in the box around what rises above the table (and the holes it may bridge).
    pad = cfg.bridge + 1
    r0, r1 = max(int(rows_in[0]) - pad, 0), min(int(rows_in[-1]) + pad + 1, k.height)
    c0, c1 = max(int(cols_in[0]) - pad, 0), min(int(cols_in[-1]) + pad + 1, k.width)
    box = (slice(r0, r1), slice(c0, c1))
    up, seen_px = above[box], measured[box]
    region = up
    if cfg.bridge > 0 and not seen_px.all():
        near = ndimage.binary_dilation(up, structure=np.ones((3, 3), dtype=bool), iterations=cfg.bridge)
        region = up | (near & ~seen_px)
    labels, count = ndimage.label(region, structure=np.ones((3, 3), dtype=bool))
    n = table_from_camera[2, :3]  # row 2 of the rotation: the table's z axis in camera coordinates
    rows, cols = np.divmod(np.flatnonzero(up), c1 - c0)
    lab = labels[rows, cols]
    rows, cols = rows + r0, cols + c0
    z = depth[rows, cols].astype(np.float64)
    xn, yn = (cols - k.cx) / k.fx, (rows - k.cy) / k.fy
    cos_inc = np.maximum(np.abs(n[0] * xn + n[1] * yn + n[2]), 0.05)
    areas = np.bincount(lab, weights=z * z / (k.fx * k.fy) / cos_inc, minlength=count + 1)
    seen = np.bincount(lab, minlength=count + 1)
    unseen = np.zeros_like(seen)
    if region is not up:  # the holes bridged into each region
        unseen = np.bincount(labels[region & ~seen_px], minlength=count + 1)
    keep = np.flatnonzero(areas >= cfg.min_area)
    keep = keep[keep > 0]
    if cfg.core > 0 and keep.size:
        core = ndimage.binary_erosion(up, structure=np.ones((3, 3), dtype=bool), iterations=cfg.core)
        keep = np.intersect1d(keep, labels[core])
    if keep.size == 0:
        return []
    slices = ndimage.find_objects(labels)
    out = [_region_object(labels[sl] == lab_id, up[sl], sl, (r0, c0), above.shape, depth, height, k,
                          table_from_camera, cfg, float(areas[lab_id]),
                          float(seen[lab_id] / (seen[lab_id] + unseen[lab_id])))
           for lab_id in keep for sl in (slices[lab_id - 1],)]
    if cfg.touching:
        out = [part for o in out for part in _touching(o, depth, height, k, table_from_camera, cfg)]
    out.sort(key=lambda o: (o.rejected is not None, o.rejected is None and not o.central,
                            o.centre_distance if o.rejected is None and not o.central else 0.0, -o.area))
    out = [replace(o, index=i) for i, o in enumerate(out)]
    return _name_halves(out)


def _touching(obj: TableObject, depth: NDArray[np.float32], height: NDArray[np.float32], k: CameraIntrinsics,
              table_from_camera: NDArray[np.float64], cfg: SegmentConfig) -> list[TableObject]:
    """The object, or the two objects touching it is split into, or the object with a note that it may be
    two (:func:`tognet.planning.touching.judge`): only for regions that look like something to pick up."""
    if not obj.qualifies or obj.area < 2 * cfg.part_area:
        return [obj]
    left, top, right, bottom = obj.box
    pad = 3
    r0, c0 = max(top - pad, 0), max(left - pad, 0)
    box = (slice(r0, min(bottom + pad, k.height)), slice(c0, min(right + pad, k.width)))
    verdict = judge(obj.mask[box], height[box], float(np.sqrt(obj.area / obj.mask.sum())), cfg)
    if verdict.labels is None:
        return [obj] if verdict.note is None else [replace(obj, touching=verdict.note)]
    halves = []
    for i in (1, 2):
        mask = np.zeros_like(obj.mask)
        mask[box] = (verdict.labels == i) & obj.mask[box]
        rows, cols = np.nonzero(mask)
        sl = (slice(int(rows.min()), int(rows.max()) + 1), slice(int(cols.min()), int(cols.max()) + 1))
        half = _region_object(mask[sl], mask[sl], sl, (0, 0), mask.shape, depth, height, k, table_from_camera,
                              cfg, _footprint(rows, cols, depth, k, table_from_camera), obj.measured)
        halves.append(replace(half, touching=verdict.note, split=True))
    return halves


def _footprint(rows: NDArray[np.int64], cols: NDArray[np.int64], depth: NDArray[np.float32],
               k: CameraIntrinsics, table_from_camera: NDArray[np.float64]) -> float:
    """The area (m^2) the pixels (rows, cols) cover on the table, seen from above."""
    n = table_from_camera[2, :3]
    z = depth[rows, cols].astype(np.float64)
    xn, yn = (cols - k.cx) / k.fx, (rows - k.cy) / k.fy
    cos_inc = np.maximum(np.abs(n[0] * xn + n[1] * yn + n[2]), 0.05)
    return float(np.sum(z * z / (k.fx * k.fy) / cos_inc))


def _name_halves(objects: list[TableObject]) -> list[TableObject]:
    """The two objects split from one region each name the other (their ``touching`` notes are the
    region's, word for word)."""
    out = list(objects)
    waiting: dict[str, int] = {}
    for i, o in enumerate(objects):
        if not o.split or o.touching is None:
            continue
        j = waiting.pop(o.touching, None)
        if j is None:
            waiting[o.touching] = i
            continue
        out[i] = replace(o, touching=f"is one of two objects touching, split from one region with #{j}: "
                         + o.touching)
        out[j] = replace(objects[j], touching=f"is one of two objects touching, split from one region with "
                         f"#{i}: {o.touching}")
    return out


@dataclass(frozen=True)
class Verdict:
    """Whether a region is two objects touching: ``labels`` (1, 2 per pixel of its box; 0 elsewhere) when it
    is split, ``note``: why (or, without labels, why it may be two: a warning), None when one object."""

    labels: NDArray[np.int32] | None = None
    note: str | None = None


def judge(mask: NDArray[np.bool_], height: NDArray[np.float32], pixel: float, cfg: SegmentConfig) -> Verdict:
    """Whether the region ``mask`` (a box around it, ``height``: m above the table, NaN holes; ``pixel``:
    its pixels' size on the table, m) is two objects touching: split where its heights fall into a valley
    between two tops (``valley_depth``, ``valley_ratio``), reported where its footprint pinches between two
    parts (``neck_ratio``); never for a container (a rim around a floor) nor where one part is a handle
    running into the other (``handle_*``). See :mod:`tognet.planning.touching`."""
    region, h = smoothed_heights(mask, height)
    verdict = _valley_split(region, h, pixel, cfg)
    if verdict is None:
        verdict = _pinch_note(region, h, pixel, cfg)
    if verdict is None:
        return Verdict()
    top = float(np.percentile(h[region], 99))
    if enclosed_floor(region, h, cfg.min_height, top, pixel * pixel) >= cfg.part_area:
        return Verdict()  # a container: its rim around its floor
    return verdict


def _valley_split(region: NDArray[np.bool_], h: NDArray[np.float64], pixel: float, cfg: SegmentConfig
                  ) -> Verdict | None:
    """The split at a valley between two tops, None without one deep enough (or where it cuts a handle)."""
    area = pixel * pixel
    valley = find_valley(region, h, area, cfg.part_area, cfg.min_height)
    if (valley is None or valley.depth < cfg.valley_depth
            or valley.saddle > cfg.valley_ratio * valley.peaks[1]):
        return None
    labels = split_labels(region, h, valley.seeds)
    sizes = [float(np.count_nonzero(labels == i)) * area for i in (1, 2)]
    neck = neck_point(region, valley.seeds == 1, valley.seeds == 2)
    if (min(sizes) < cfg.part_area or _handle(valley.seeds, neck, cfg)
            or _handle(labels, cut_point(labels), cfg)):
        return None
    tops = f"{1000 * valley.peaks[0]:.0f} and {1000 * valley.peaks[1]:.0f} mm high"
    return Verdict(labels, f"the lowest way between their tops ({tops}) goes down to "
                   f"{1000 * valley.saddle:.0f} mm")


def _pinch_note(region: NDArray[np.bool_], h: NDArray[np.float64], pixel: float, cfg: SegmentConfig
                ) -> Verdict | None:
    """The warning where the footprint pinches between two parts, None without a narrow enough pinch (or
    where a handle runs into the pinch)."""
    area = pixel * pixel
    seeds = neck_seeds(region, area, cfg.part_area)
    if seeds is None:
        return None
    pinch = find_pinch(region, seeds, pixel)
    if pinch is None or pinch.width > cfg.neck_ratio * min(pinch.part_widths):
        return None
    labels = split_labels(region, h, seeds)
    if _handle(seeds, pinch.at, cfg) or _handle(labels, pinch.at, cfg):
        return None
    sizes = sorted((float(np.count_nonzero(labels == i)) * area for i in (1, 2)), reverse=True)
    return Verdict(None, f"may be two objects touching: its footprint narrows to {1000 * pinch.width:.0f} mm "
                   f"between two parts of {1e4 * sizes[0]:.0f} and {1e4 * sizes[1]:.0f} cm^2")


def _handle(labels: NDArray[np.int32], at: tuple[int, int] | None, cfg: SegmentConfig) -> bool:
    """Whether one of the two parts (labels 1, 2: the tops a valley or an erosion left apart, or the halves
    grown from them; both are asked, the halves' edges being the less sure) is a handle ending where they
    meet (``at``): a convex, elongated piece whose long axis runs through there, as a hammer's handle runs
    into its head: one tool, not two."""
    if at is None:
        return True
    for i in (1, 2):
        part = labels == i
        if (solidity(part) >= cfg.handle_solidity
                and elongation(part) >= cfg.handle_elongation
                and axis_offset(part, at) <= cfg.handle_offset):
            return True
    return False


def _region_object(in_label: NDArray[np.bool_], up: NDArray[np.bool_], sl: tuple[slice, slice],
                   offset: tuple[int, int], shape: tuple[int, ...], depth: NDArray[np.float32],
                   height: NDArray[np.float32], k: CameraIntrinsics, table_from_camera: NDArray[np.float64],
                   cfg: SegmentConfig, area: float, share: float) -> TableObject:
    """One labelled region (its bounding box ``sl`` within the search box at ``offset``) as a
    :class:`TableObject`: mask, height, footprint centre and thickness, border, reach to the image's
    centre, and whether (and why) it is rejected; ``index`` 0 until the list is sorted."""
    r0, c0 = offset
    local = in_label & up
    top_row, left = sl[0].start + r0, sl[1].start + c0
    bottom, right = sl[0].stop + r0, sl[1].stop + c0
    mask = np.zeros(shape, dtype=bool)
    mask[top_row:bottom, left:right] = local
    lr, lc = np.nonzero(local)
    lr, lc = lr + top_row, lc + left
    zz = depth[lr, lc].astype(np.float64)
    r, t = table_from_camera[:3, :3], table_from_camera[:3, 3]
    pts = np.column_stack([(lc - k.cx) / k.fx * zz, (lr - k.cy) / k.fy * zz, zz]) @ r.T + t
    hs = height[lr, lc].astype(np.float64)
    lo, top = np.percentile(hs, [5.0, 99.0])
    xy = pts[:, :2] - pts[:, :2].mean(axis=0)
    _, vecs = np.linalg.eigh(xy.T @ xy)
    across = xy @ vecs[:, 0]  # along the footprint's narrow direction
    thickness = float(np.subtract(*np.percentile(across, [95.0, 5.0])))
    centre = np.array([*pts[:, :2].mean(axis=0), 0.0])
    border = bool(top_row == 0 or left == 0 or bottom == k.height or right == k.width)
    reach = float(np.min(np.hypot(lc - 0.5 * (k.width - 1), lr - 0.5 * (k.height - 1))))
    return TableObject(
        mask, area, float(top), centre, border, share, (float(lc.mean()), float(lr.mean())),
        (left, top_row, right, bottom),
        _rejection(cfg, area, float(top), share, thickness, float(top - lo), border), 0, reach,
        reach <= cfg.centre_zone * min(k.width, k.height))


def choice_reason(fit: list[TableObject], first: int = 0) -> str:
    """Why ``fit[first]`` is planned on, of the objects ``fit`` that look like something to pick up, in
    :func:`segment_objects`' order."""
    central = [o for o in fit if o.central]
    if fit[first].central:
        if len(central) == 1:
            return (f"the only one near the image's centre of the {len(fit)} objects that look like "
                    "something to pick up")
        return (f"the largest of the {len(central)} objects near the image's centre that look like something "
                "to pick up" + (" on which the gripper finds a grasp" if first else ""))
    return (f"the nearest to the image's centre of the {len(fit)} objects that look like something to pick up"
            + (" on which the gripper finds a grasp" if first else ""))


def pick_object(objects: list[TableObject], choice: int | tuple[float, float] | None = None,
                near: float = 15.0) -> tuple[TableObject, str]:
    """The object to plan on and why: ``choice`` None: the first of :func:`segment_objects`' list that
    looks like something to pick up (the largest near the image's centre, else the nearest to it); an int:
    that index of ``objects``; (u, v): the object at that pixel (or the nearest within ``near`` pixels).
    Raises :class:`NoObjectError` naming what was seen when there is nothing to choose."""
    if choice is None:
        fit = [o for o in objects if o.qualifies]
        if not fit:
            raise NoObjectError("no object on the table looks like something the gripper can pick up; seen: "
                                + "; ".join(o.summary() for o in objects[:4])
                                + (f"; and {len(objects) - 4} more" if len(objects) > 4 else ""))
        if len(fit) == 1:
            return fit[0], "the only object that looks like something to pick up"
        return fit[0], choice_reason(fit)
    if isinstance(choice, int | np.integer) and not isinstance(choice, bool):
        i = int(choice)
        if not 0 <= i < len(objects):
            raise NoObjectError(f"no object #{i}: the image shows {len(objects)} (#0 to "
                                f"#{len(objects) - 1}): " + "; ".join(o.summary() for o in objects[:6]))
        return objects[i], f"object #{i}, as asked"
    try:
        u, v = (float(c) for c in choice)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(f"an object is chosen by its index or by a pixel (u, v), got {choice!r}") from None
    best, dist = None, math.inf
    for o in objects:
        rows, cols = np.nonzero(o.mask)
        d = float(np.min(np.hypot(cols - u, rows - v)))
        if d < dist:
            best, dist = o, d
    if best is None or dist > near:
        seen = "; ".join(o.summary() for o in objects[:6]) if objects else "nothing stands on the table"
        raise NoObjectError(f"no object at pixel ({u:g}, {v:g}) (none within {near:g} pixels); seen: {seen}")
    return best, f"object #{best.index}, at pixel ({u:g}, {v:g}) as asked"


def mask_to_table(depth: NDArray[np.float32], mask: NDArray[np.bool_], plane: TablePlane,
                  intrinsics: CameraIntrinsics, margin: int = 2) -> NDArray[np.float32]:
    """``depth`` with the pixels of ``mask`` (grown by ``margin``) replaced by the table plane's depth."""
    grown = ndimage.binary_dilation(mask, iterations=margin) if margin > 0 else mask
    out = depth.copy()
    out[grown] = plane.depth_of_rays(intrinsics)[grown]
    return out
