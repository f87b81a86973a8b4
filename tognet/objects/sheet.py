"""Contact sheet: every object of a set seen from above and from the side, on one PNG (matplotlib).

Each cell shows the visual mesh as shaded filled triangles (painter's order, Lambert shading), the top
view (x right, y up) over the side view (x right, z up), all cells at the same scale with a 10 cm bar,
labelled with id, shape rule, part types and mass.
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


def write_contact_sheet(set_dir: Path, out_png: Path, max_objects: int = 24) -> Path:
    """Write a PNG grid of (up to ``max_objects``) objects of ``set_dir``, top and side views."""
    set_dir, out_png = Path(set_dir), Path(out_png)
    records = sorted(load_catalog(set_dir), key=lambda r: r.object_id)[: max(1, max_objects)]
    if not records:
        raise ValueError(f"{set_dir}: the catalog lists no objects")
    meshes: list[trimesh.Trimesh] = [r.load_mesh(r.visual_mesh) for r in records]
    half_xy = max(float(np.max(np.abs(m.vertices[:, :2]))) for m in meshes) * 1.05
    half_z = max(float(np.max(np.abs(m.vertices[:, 2]))) for m in meshes) * 1.2
    cols = min(6, len(records))
    rows = math.ceil(len(records) / cols)
    side_ratio = max(0.25, half_z / half_xy)
    height = rows * 2.6 * (1 + side_ratio) * 1.06 + 0.5
    fig = plt.figure(figsize=(2.6 * cols, height))
    grid = fig.add_gridspec(
        2 * rows,
        cols,
        height_ratios=[1.0, side_ratio] * rows,
        hspace=0.06,
        wspace=0.05,
        left=0.01,
        right=0.99,
        bottom=0.01,
        top=1.0 - 0.5 / height,
    )
    for i, (record, mesh) in enumerate(zip(records, meshes, strict=True)):
        r, c = divmod(i, cols)
        colour = _COLOURS.get(record.kind, _DEFAULT_COLOUR)
        top = fig.add_subplot(grid[2 * r, c])
        side = fig.add_subplot(grid[2 * r + 1, c])
        _draw(top, mesh, "top", colour)
        _draw(side, mesh, "side", colour)
        top.set_xlim(-half_xy, half_xy)
        top.set_ylim(-half_xy, half_xy)
        side.set_xlim(-half_xy, half_xy)
        side.set_ylim(-half_z, half_z)
        for ax in (top, side):
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
        side.axhline(float(mesh.bounds[0, 2]), color="0.5", linewidth=0.6)
        bar_y = -0.92 * half_xy
        top.plot([-0.95 * half_xy, -0.95 * half_xy + 0.1], [bar_y, bar_y], color="k", linewidth=1.5)
        top.text(
            0.03, 0.97, _label(record), transform=top.transAxes, fontsize=6.5, va="top", family="monospace"
        )
    fig.suptitle(
        f"{set_dir.name}: {len(records)} objects (top: from above, bottom: from the side; bar 10 cm)",
        y=1.0 - 0.15 / height,
    )
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return out_png
