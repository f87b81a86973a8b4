"""``tognet grasps``: sample antipodal grasp candidates on a depth image and draw them.

Candidates are coloured by a score: the analytic antipodality quality by default, or any scorer
(``score_fn(grasps (M, 4)) -> (M,)``) through :func:`tognet.grasping.draw.render_grasps`. ``--checkpoint``
colours them by a trained TOG-Net's Q_T (``tognet.model.scorer_from_checkpoint(path, scene) -> score_fn``).
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from tognet.cliutil import user_errors
from tognet.config import ConfigError
from tognet.errors import TognetError
from tognet.geometry import Camera
from tognet.grasping.antipodal import AntipodalConfig
from tognet.grasping.cem import ScoreFn
from tognet.grasping.depth import DepthScene, load_depth_file, prepare_depth
from tognet.grasping.draw import render_grasps


def antipodal_config(value: str | None) -> AntipodalConfig:
    """``--config``: None (the defaults), inline JSON (``{...}``) or a JSON file; ConfigError otherwise."""
    if value is None:
        return AntipodalConfig()
    if value.lstrip().startswith("{"):
        try:
            data = json.loads(value)
        except json.JSONDecodeError as exc:
            raise ConfigError(f"--config: not valid JSON ({exc})") from None
        data.pop("config_type", None)
        return AntipodalConfig.from_dict(data, where="--config")
    return AntipodalConfig.load(value)


def load_scorer(checkpoint: Path, scene: DepthScene) -> ScoreFn:
    """The hook for a learned scorer: ``tognet.model.scorer_from_checkpoint(checkpoint, scene)``."""
    if not checkpoint.is_file():
        raise FileNotFoundError(f"checkpoint not found: {checkpoint}")
    from tognet.model.predict import scorer_from_checkpoint

    return scorer_from_checkpoint(checkpoint, scene)


@user_errors
def grasps(
    depth: Path = typer.Option(..., "--depth", help="Depth image: .npy/.npz (metres) or 16-bit .png (mm)."),
    camera: Path = typer.Option(..., "--camera", help="Camera JSON written by Camera.save."),
    out: Path = typer.Option(..., "--out", help="PNG to write (the depth image with the jaw lines)."),
    max_candidates: int | None = typer.Option(
        None, "--max", min=1, help="Maximum number of candidates (default: the config's, 200)."),
    seed: int = typer.Option(0, "--seed", help="Random seed of the sampler."),
    checkpoint: Path | None = typer.Option(
        None, "--checkpoint", help="TOG-Net checkpoint (best.pt): colour the candidates by its Q_T."
    ),
    use_nms: bool = typer.Option(
        False, "--nms", help="Draw only the grasps kept by non-maximum suppression."
    ),
    use_cem: bool = typer.Option(
        False, "--cem", help="With --checkpoint: refine by the cross-entropy method, best grasp drawn in red."
    ),
    config: str | None = typer.Option(
        None, "--config", help="AntipodalConfig: a JSON file, or inline JSON such as '{\"max_width\": 0.06}' "
        "(defaults otherwise)."),
) -> None:
    """Sample antipodal grasp candidates on a depth image and draw them, coloured by score."""
    if out.is_dir():
        raise TognetError(f"--out {out} is a directory; give a .png file name")
    if out.suffix.lower() != ".png":
        raise TognetError(f"--out {out}: the drawing is written as PNG; use a .png file name")
    cfg = antipodal_config(config)
    if max_candidates is not None:
        cfg = cfg.replace(max_candidates=max_candidates)
    try:
        cam = Camera.load(camera)
    except ValueError as exc:
        message = str(exc)
        raise TognetError(message if str(camera) in message else f"{camera}: {message}") from exc
    image = load_depth_file(depth)
    try:
        scene = prepare_depth(image, cam)
    except ValueError as exc:
        raise TognetError(f"{depth}: {exc}") from exc
    score_fn = load_scorer(checkpoint, scene) if checkpoint is not None else None
    cands, scores, path = render_grasps(
        scene, out, config=cfg, seed=seed, score_fn=score_fn, use_nms=use_nms, use_cem=use_cem
    )
    if len(cands) == 0:
        typer.echo(f"no grasp candidates found; wrote {path}")
        return
    typer.echo(
        f"{len(cands)} candidates (width {1000 * cands.widths.min():.0f}-{1000 * cands.widths.max():.0f} mm, "
        f"score {scores.min():.2f}-{scores.max():.2f}); wrote {path}"
    )


def register(app: typer.Typer) -> None:
    """Add ``grasps`` to the tognet command."""
    app.command("grasps")(grasps)
