"""Contact sheet: every object of a set seen from above and from the side, on one PNG (matplotlib).

Each cell shows the visual mesh as shaded filled triangles (painter's order, Lambert shading), the top
view (x right, y up) over the side view (x right, z up, the object standing on a ground line), all cells
at the same scale with a 10 cm bar, under a label with id, shape rule, part types, mass and size.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import trimesh  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

from tognet.io import atomic_path
from tognet.objects.record import ObjectRecord, load_catalog  # noqa: E402

_COLOURS = {"primitive": (0.35, 0.55, 0.85), "complex": (0.85, 0.55, 0.3), "realistic": (0.4, 0.7, 0.45)}
_DEFAULT_COLOUR = (0.6, 0.6, 0.65)


def _draw(ax: plt.Axes, mesh: trimesh.Trimesh, view: str, colour: tuple[float, float, float]) -> None:
    """Project ``mesh`` orthographically: ``view`` 'top' looks down -z, 'side' looks along +y."""
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]
    normals = np.asarray(mesh.face_normals)
    if view == "top":
        plane, depth, towards = (0, 1), tri[:, :, 2].mean(axis=1), normals[:, 2]
        order = np.argsort(depth)  # lowest first, highest drawn last
        light = np.array([-0.3, 0.4, 1.0])
    else:
        plane, depth, towards = (0, 2), tri[:, :, 1].mean(axis=1), -normals[:, 1]
        order = np.argsort(-depth)  # farthest (largest y) first
        light = np.array([-0.3, -1.0, 0.5])
    light = light / np.linalg.norm(light)
    visible = order[towards[order] > -1e-9]
    shade = 0.35 + 0.65 * np.clip(normals[visible] @ light, 0.0, 1.0)
    colours = np.clip(np.asarray(colour)[None, :] * shade[:, None], 0.0, 1.0)
    polys = tri[visible][:, :, list(plane)]
    ax.add_collection(PolyCollection(polys, facecolors=colours, edgecolors=colours, linewidths=0.2))


def _label(record: ObjectRecord) -> str:
    extra = record.extra if isinstance(record.extra, dict) else {}
    name = extra.get("name") or extra.get("source")
    parts = "+".join(dict.fromkeys(record.part_types)) if record.part_types else ""
    first = record.object_id
    second = f"{record.shape_rule} {parts}" if record.shape_rule not in ("", "none") else (name or parts)
    dims = "x".join(f"{100 * e:.0f}" for e in record.extents)
    return f"{first}\n{second}\n{1000 * record.mass:.0f} g, {dims} cm"


def _extent(meshes: list[trimesh.Trimesh], axis: int) -> float:
    return max(float(np.max(np.abs(np.asarray(m.vertices)[:, axis]))) for m in meshes)


def _spans(meshes: list[trimesh.Trimesh]) -> tuple[float, float, float]:
    """The sheet's common half widths in x and y of a top view and height of a side view (m)."""
    half_x = _extent(meshes, 0) * 1.06 + 0.005
    half_y = _extent(meshes, 1) * 1.1 + 0.005
    half_y = max(half_y, 0.45 * half_x)  # room for the label and the scale bar
    tallest = max(float(np.ptp(np.asarray(m.vertices)[:, 2])) for m in meshes)
    z_span = max(tallest * 1.25, 2 * half_y / 3)
    return half_x, half_y, z_span


def _draw_cell(top: plt.Axes, side: plt.Axes, record: ObjectRecord, mesh: trimesh.Trimesh, half_x: float,
               half_y: float, z_span: float) -> None:
    """Draw one object's top and side views (standing on the ground line), label and 10 cm bar."""
    colour = _COLOURS.get(record.kind, _DEFAULT_COLOUR)
    standing = mesh.copy()
    standing.vertices = np.asarray(standing.vertices) - [0.0, 0.0, float(mesh.bounds[0, 2])]
    _draw(top, mesh, "top", colour)
    _draw(side, standing, "side", colour)
    top.set_xlim(-half_x, half_x)
    top.set_ylim(-half_y, half_y)
    side.set_xlim(-half_x, half_x)
    side.set_ylim(-0.1 * z_span, 0.9 * z_span)
    for ax in (top, side):
        ax.set_aspect("equal", anchor="S" if ax is top else "N")
        ax.set_xticks([])
        ax.set_yticks([])
    top.set_title(_label(record), fontsize=6.5, family="monospace", loc="left", pad=2)
    side.axhline(0.0, color="0.45", linewidth=0.8)
    side.text(0.99, 0.93, "side", transform=side.transAxes, fontsize=6, ha="right", va="top", color="0.4")
    top.text(0.99, 0.97, "top", transform=top.transAxes, fontsize=6, ha="right", va="top", color="0.4")
    bar_y = -0.9 * half_y
    top.plot([-0.96 * half_x, -0.96 * half_x + 0.1], [bar_y, bar_y], color="k", linewidth=1.5)
    top.text(-0.96 * half_x + 0.05, bar_y, "10 cm", fontsize=6, ha="center", va="bottom")


def write_contact_sheet(
    set_dir: Path, out_png: Path, max_objects: int = 24, columns: int | None = None
) -> Path:
    """Write a PNG grid of (up to ``max_objects``) objects of ``set_dir``, top and side views.

    ``columns`` defaults to 4 (6 for more than 16 objects).
    Every panel of the sheet has the same scale (a 10 cm bar in each top view). Top views span the
    sheet's largest |x| and |y| (not a square, so flat, long tools get wide panels); side views stand
    each object on a ground line and span the sheet's tallest object, at least a third of the top
    view's height so the side of a flat tool is still a readable band.
    """
    set_dir, out_png = Path(set_dir), Path(out_png)
    if out_png.suffix.lower() != ".png":
        raise ValueError(f"--out {out_png}: the contact sheet is a PNG, give a file name ending in .png")
    if out_png.exists() and out_png.is_dir():
        raise ValueError(f"--out {out_png} is a folder; give a PNG file name")
    records = sorted(load_catalog(set_dir), key=lambda r: r.object_id)[: max(1, max_objects)]
    if not records:
        raise ValueError(f"{set_dir}: the catalog lists no objects")
    meshes: list[trimesh.Trimesh] = [r.load_mesh(r.visual_mesh) for r in records]
    half_x, half_y, z_span = _spans(meshes)
    columns = columns or (4 if len(records) <= 16 else 6)
    cols = max(1, min(columns, len(records)))
    rows = math.ceil(len(records) / cols)
    cell_w = 3.4
    top_h = cell_w * half_y / half_x
    side_h = cell_w * z_span / (2 * half_x)
    label_h = 0.42
    cell_h = label_h + top_h + side_h + 0.12
    title_h = 0.55
    height = rows * cell_h + title_h
    fig = plt.figure(figsize=(cell_w * cols + 0.1 * (cols + 1), height))
    grid = fig.add_gridspec(
        2 * rows,
        cols,
        height_ratios=[top_h + label_h, side_h] * rows,
        hspace=0.0,
        wspace=0.06,
        left=0.01,
        right=0.99,
        bottom=0.01,
        top=1.0 - title_h / height,
    )
    for i, (record, mesh) in enumerate(zip(records, meshes, strict=True)):
        r, c = divmod(i, cols)
        top = fig.add_subplot(grid[2 * r, c])
        side = fig.add_subplot(grid[2 * r + 1, c])
        _draw_cell(top, side, record, mesh, half_x, half_y, z_span)
    fig.suptitle(
        f"{set_dir.name}: {len(records)} objects, each from above (top) and from the side (below it, "
        "on a ground line); one scale for all",
        y=1.0 - 0.12 / height,
        fontsize=10,
    )
    out_png.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out_png) as tmp:
        fig.savefig(tmp, dpi=130, bbox_inches="tight")
    plt.close(fig)
    return out_png
