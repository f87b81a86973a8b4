"""``tognet grasps``: sample antipodal grasp candidates on a depth image and draw them.

Candidates are coloured by a score: the analytic antipodality quality by default, or any scorer
(``score_fn(grasps (M, 4)) -> (M,)``) through :func:`tognet.grasping.draw.render_grasps`. ``--checkpoint``
colours them by a trained TOG-Net's Q_T (``tognet.model.scorer_from_checkpoint(path, scene) -> score_fn``),
or by Q_G for the grasp-only model (its Q_T is meaningless: it never learned a task).
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from tognet.cli.util import out_file, user_errors
from tognet.config import ConfigError
from tognet.errors import TognetError
from tognet.geometry import Camera
from tognet.grasping.antipodal import AntipodalConfig
from tognet.grasping.cem import ScoreFn
from tognet.grasping.depth import DepthScene, load_depth_file, prepare_depth
from tognet.grasping.draw import render_grasps
from tognet.tasks import GRASP_ONLY


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


def checkpoint_score(checkpoint: Path) -> str:
    """Which score ``--checkpoint`` colours by: ``grasp`` (Q_G) for the grasp-only model, else ``task``
    (Q_T). The checkpoint is read (a missing or broken file is a one-line error)."""
    from tognet.model.checkpoint import load_checkpoint

    return "grasp" if load_checkpoint(checkpoint).get("task") == GRASP_ONLY else "task"


def load_scorer(checkpoint: Path, scene: DepthScene, kind: str = "task") -> ScoreFn:
    """The hook for a learned scorer: ``tognet.model.scorer_from_checkpoint(checkpoint, scene, kind)``."""
    if not checkpoint.is_file():
        raise FileNotFoundError(f"checkpoint not found: {checkpoint}")
    from tognet.model.predict import scorer_from_checkpoint

    return scorer_from_checkpoint(checkpoint, scene, kind)


def load_camera(camera: Path, camera_pose: Path | None) -> Camera:
    """The camera of ``--camera`` (a ``Camera.save`` JSON with intrinsics and pose, or an intrinsics file
    as ``tognet sim --depth-png`` writes) and ``--camera-pose`` (a pose file; replaces the camera file's
    pose). Every problem is a one-line error naming the file and the field."""
    from tognet.planning.camera import CameraFileError, load_camera_pose, load_intrinsics

    if camera.is_dir():
        raise CameraFileError(f"--camera {camera}: is a folder; give the camera JSON file")
    if not camera.is_file():
        raise CameraFileError(f"--camera {camera}: camera file not found")
    k = load_intrinsics(camera)
    if camera_pose is not None:
        pose = load_camera_pose(camera_pose)
    else:
        try:
            data = json.loads(camera.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):  # load_intrinsics has read it already
            data = {}
        if not (isinstance(data, dict) and ("world_from_camera" in data or "pose" in data)):
            raise CameraFileError(
                f"--camera {camera}: holds intrinsics but no pose; pass --camera-pose FILE too (`tognet sim "
                "--depth-png d.png` writes d.intrinsics.json and d.pose.json)")
        pose = load_camera_pose(camera)
    return Camera(k, pose)


@user_errors
def grasps(
    depth: Path = typer.Option(..., "--depth", help="Depth image: .npy/.npz (float metres, or integer "
                               "millimetres) or 16-bit .png (millimetres, 0 = no reading)."),
    camera: Path = typer.Option(..., "--camera", help="Camera JSON: {width, height, fx, fy, cx, cy (pixels), "
                                "\"world_from_camera\": 4 x 4} (Camera.save), or an "
                                "intrinsics file such as `tognet sim --depth-png d.png` writes "
                                "(d.intrinsics.json) with --camera-pose."),
    camera_pose: Path | None = typer.Option(
        None, "--camera-pose", help="Camera pose JSON {\"world_from_camera\": 4 x 4} (e.g. d.pose.json from "
        "`tognet sim --depth-png d.png`); world z = 0 is the table top."),
    out: Path = typer.Option(..., "--out", help="PNG to write (the depth image with the jaw lines)."),
    max_candidates: int | None = typer.Option(
        None, "--max", min=1, help="Maximum number of candidates (default: the config's, 200)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Random seed of the sampler."),
    checkpoint: Path | None = typer.Option(
        None, "--checkpoint", help="TOG-Net checkpoint (e.g. tognet/models/hammering.pt): colour the "
        "candidates by its Q_T; the grasp-only model (tognet/models/grasping.pt) by its Q_G."
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
    """Sample antipodal grasp candidates on a depth image and draw them, coloured by score.

    Prints how many candidates were found, their widths and score range, and writes --out: the depth image
    with each candidate's jaw line coloured by its score (analytic antipodality by default; the model's Q_T,
    or Q_G for the grasp-only model, with --checkpoint)."""
    out_file(out, "--out", ".png")
    cfg = antipodal_config(config)
    if max_candidates is not None:
        cfg = cfg.replace(max_candidates=max_candidates)
    if use_cem and checkpoint is None:
        raise TognetError("--cem needs a scorer (--checkpoint): the analytic quality only exists for "
                          "candidates")
    cam = load_camera(camera, camera_pose)
    image = load_depth_file(depth)
    try:
        scene = prepare_depth(image, cam)
    except ValueError as exc:
        raise TognetError(f"{depth}: {exc}") from exc
    kind = checkpoint_score(checkpoint) if checkpoint is not None else None
    score_fn = load_scorer(checkpoint, scene, kind) if checkpoint is not None and kind else None
    name = {"grasp": "Q_G", "task": "Q_T", None: "analytic quality"}[kind]
    cands, scores, path = render_grasps(
        scene, out, config=cfg, seed=seed, score_fn=score_fn, use_nms=use_nms, use_cem=use_cem,
        score_name=name,
    )
    if len(cands) == 0:
        typer.echo(f"no grasp candidates found; wrote {path}")
        return
    typer.echo(
        f"{len(cands)} candidates (width {1000 * cands.widths.min():.0f}-{1000 * cands.widths.max():.0f} mm, "
        f"{name} {scores.min():.3g} to {scores.max():.3g}); wrote {path}"
    )


def register(app: typer.Typer) -> None:
    """Add ``grasps`` to the tognet command."""
    app.command("grasps")(grasps)
