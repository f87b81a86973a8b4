"""Draw grasp candidates (jaw lines) on a depth image, coloured by a score; :func:`render_grasps` samples,
scores and draws them in one call (``tognet grasps``, the demo)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError
from tognet.geometry import Camera
from tognet.grasping.antipodal import AntipodalConfig, GraspCandidates, sample_antipodal
from tognet.grasping.cem import CEMConfig, ScoreFn, cem
from tognet.grasping.depth import DepthScene
from tognet.grasping.nms import NMSConfig, nms
from tognet.io import atomic_path


def depth_to_rgb(depth: NDArray[np.float32], table: NDArray[np.float32] | None = None,
                 span: float = 0.05) -> NDArray[np.uint8]:
    """Grey-scale rendering (near = bright) of a depth image; holes are dark red.

    ``table``: the table's depth along every pixel's ray (the plane's, see
    :meth:`tognet.planning.table.TablePlane.depth_of_rays`): the grey then shows how far in front of the
    table each surface is, from black (the table) to white (``span`` m or more), whatever the camera's tilt
    (a global scale lets a tool on the far half of a tilted table fade into it); surfaces more than 2 cm
    behind the table (a floor past its edge) are dark blue."""
    valid = np.isfinite(depth)
    if table is not None:
        rel = np.asarray(table, dtype=np.float64) - np.where(valid, depth, np.nan)
        grey = np.clip(np.nan_to_num(rel, nan=0.0) / max(span, 1e-6), 0, 1) * 200 + 30
        rgb = np.repeat(grey[..., None], 3, axis=2).astype(np.uint8)
        with np.errstate(invalid="ignore"):
            rgb[valid & (rel < -0.02)] = (0, 20, 90)
        rgb[~valid] = (90, 0, 0)
        return rgb
    if valid.any():
        # Near end: the nearest percent; far end: just beyond the median (the table), so that a floor
        # seen past the table's edge does not wash out the objects' few centimetres of relief.
        lo, med = np.percentile(depth[valid], [1, 50])
        hi = med + 0.02
    else:
        lo, hi = 0.0, 1.0
    span = max(float(hi - lo), 1e-6)
    grey = np.clip((hi - np.nan_to_num(depth, nan=hi)) / span, 0, 1) * 200 + 30
    rgb = np.repeat(grey[..., None], 3, axis=2).astype(np.uint8)
    rgb[~valid] = (90, 0, 0)
    return rgb


def jaw_endpoints(camera: Camera, grasps: NDArray[np.float64], widths: NDArray[np.float64]) -> NDArray:
    """(N, 2, 2) pixel coordinates of both fingers of each grasp (jaw line ends)."""
    grasps = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
    half = 0.5 * np.asarray(widths, dtype=np.float64).reshape(-1)
    axis = np.column_stack([np.cos(grasps[:, 3]), np.sin(grasps[:, 3]), np.zeros(len(grasps))])
    ends = np.stack([grasps[:, :3] - axis * half[:, None], grasps[:, :3] + axis * half[:, None]], axis=1)
    uv, _ = camera.project(ends.reshape(-1, 3))
    return uv.reshape(-1, 2, 2)


def draw_grasps(
    depth: NDArray[np.float32],
    camera: Camera,
    grasps: NDArray[np.float64],
    scores: NDArray[np.float64],
    out: str | Path,
    *,
    widths: NDArray[np.float64] | None = None,
    title: str = "",
    scale: int = 2,
    highlight: NDArray[np.float64] | None = None,
) -> Path:
    """Write a PNG of the depth image with one jaw line per grasp, coloured by ``scores`` (viridis).

    The line joins the two finger positions (width ``widths``, default 0.05 m); a dot marks the
    finger at phi's positive direction, so phi and phi + pi are told apart. ``highlight`` (one grasp,
    e.g. the CEM's best) is drawn in red on top.
    """
    from matplotlib import colormaps
    from PIL import Image, ImageDraw

    grasps = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    if widths is None:
        widths = np.full(len(grasps), 0.05)
    img = Image.fromarray(depth_to_rgb(depth)).resize(
        (depth.shape[1] * scale, depth.shape[0] * scale), Image.Resampling.NEAREST
    )
    draw = ImageDraw.Draw(img)
    cmap = colormaps["viridis"]
    if len(grasps):
        lo, hi = float(scores.min()), float(scores.max())
        norm = (scores - lo) / (hi - lo) if hi > lo else np.ones_like(scores)
        ends = jaw_endpoints(camera, grasps, widths) * scale
        for k in np.argsort(scores):  # best drawn last, on top
            colour = tuple(int(255 * c) for c in cmap(float(norm[k]))[:3])
            (u0, v0), (u1, v1) = ends[k]
            draw.line([(u0, v0), (u1, v1)], fill=colour, width=2)
            draw.ellipse([u1 - 3, v1 - 3, u1 + 3, v1 + 3], fill=colour)
        text = f"{title} {len(grasps)} grasps, score {lo:.2f}..{hi:.2f}".strip()
    else:
        text = f"{title} no grasp candidates".strip()
    if highlight is not None:
        (u0, v0), (u1, v1) = (
            jaw_endpoints(camera, np.asarray(highlight).reshape(1, 4), np.array([0.05]))[0] * scale
        )
        draw.line([(u0, v0), (u1, v1)], fill=(255, 40, 40), width=4)
        draw.ellipse([u1 - 5, v1 - 5, u1 + 5, v1 + 5], fill=(255, 40, 40))
    draw.text((6, 6), text, fill=(255, 255, 0))
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp:
        img.save(tmp)
    return out


def render_grasps(
    scene: DepthScene,
    out: Path,
    *,
    config: AntipodalConfig,
    seed: int = 0,
    score_fn: ScoreFn | None = None,
    use_nms: bool = False,
    nms_config: NMSConfig | None = None,
    use_cem: bool = False,
    cem_config: CEMConfig | None = None,
    score_name: str = "scorer",
) -> tuple[GraspCandidates, np.ndarray, Path]:
    """Sample candidates on ``scene``, score them (``score_fn`` or the analytic quality), draw to ``out``.

    With ``use_cem`` (needs ``score_fn``) the cross-entropy method refines the grasp from the candidates
    and its best grasp is drawn in red on top. ``score_name`` names the scorer in the picture's title.
    """
    if use_cem and score_fn is None:
        raise TognetError(
            "--cem needs a scorer (--checkpoint): the analytic quality only exists for candidates"
        )
    rng = np.random.default_rng(seed)
    cands = sample_antipodal(scene, None, config, rng)
    scores = cands.quality if score_fn is None or len(cands) == 0 else np.asarray(score_fn(cands.grasps))
    if scores.shape != (len(cands),):
        raise TognetError(f"the scorer returned shape {scores.shape} for {len(cands)} grasps")
    if use_nms and len(cands):
        keep = nms(cands.grasps, scores, nms_config or NMSConfig())
        cands, scores = cands.subset(keep), scores[keep]
    highlight = None
    label = "analytic quality" if score_fn is None else score_name
    if use_cem and score_fn is not None and len(cands):
        result = cem(score_fn, cands.grasps, cem_config or CEMConfig(), rng)
        highlight = result.best
        label += f", CEM best {result.best_score:.3f}"
    path = draw_grasps(
        scene.depth,
        scene.camera,
        cands.grasps,
        scores,
        out,
        widths=cands.widths,
        title=f"[{label}]",
        highlight=highlight,
    )
    return cands, scores, path
