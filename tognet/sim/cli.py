"""``tognet sim``: run one episode and write an animation of it."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import typer

from tognet.cliutil import user_errors


def _short(value: object) -> object:
    """``value`` with its floats (also inside lists) rounded to 4 decimals, for printing."""
    if isinstance(value, float):
        return round(value, 4)
    if isinstance(value, (list, tuple)):
        return [_short(v) for v in value]
    return value


def register(app: typer.Typer) -> None:
    """Add the ``sim`` command to the tognet app."""

    @app.command("sim")
    @user_errors
    def sim_command(
        task: str = typer.Option("hammering", help="Task: sweeping, hammering or grasping."),
        object_id: str = typer.Option(
            "", "--object", help="Object id in --objects; without --objects: t_hammer or l_tool (hand-made)."
        ),
        objects: Path | None = typer.Option(None, help="Object set folder (with catalog.json)."),
        grasp: tuple[float, float, float, float] | None = typer.Option(
            None,
            metavar="X Y Z PHI",
            help="Grasp x y z phi (world, m, rad). Default: at the centre of mass, across the narrow side.",
        ),
        action: tuple[float, float, float, float] | None = typer.Option(
            None,
            metavar="AX AY AZ APHI",
            help="Action a_x a_y a_z a_phi relative to the task's nominal start pose. Default: zeros.",
        ),
        seed: int = typer.Option(0, help="Scene seed (object drop, camera, props)."),
        trial_seed: int = typer.Option(0, help="Execution-noise seed of the trial."),
        gif: Path | None = typer.Option(None, help="Write an animation of the episode here (.gif)."),
        depth_png: Path | None = typer.Option(None, help="Write the depth image here (.png)."),
        config: Path | None = typer.Option(None, help="SimConfig JSON (default: built-in)."),
    ) -> None:
        """Run one episode (drop, depth image, grasp, lift, task primitive), print the labels, animate it."""
        import numpy as np

        from tognet.geometry import Grasp
        from tognet.objects import load_object
        from tognet.sim import SimConfig, Simulator
        from tognet.sim.tools import make_test_tools

        if task not in ("sweeping", "hammering", "grasping"):
            raise ValueError(f"unknown --task '{task}'; known: sweeping, hammering, grasping")
        for values, name in ((grasp, "--grasp"), (action, "--action")):
            if values is not None and not all(math.isfinite(v) for v in values):
                raise ValueError(f"{name} takes 4 finite numbers, got {' '.join(map(str, values))}")
        if task == "grasping" and action is not None:
            raise ValueError("--action has no use with --task grasping (the episode ends after the lift)")
        for path, suffix, name in ((gif, ".gif", "--gif"), (depth_png, ".png", "--depth-png")):
            if path is not None and (path.suffix.lower() != suffix or path.is_dir()):
                raise ValueError(f"{name} must name a {suffix} file, got '{path}'")
        cfg = SimConfig.load(config) if config else SimConfig()
        with tempfile.TemporaryDirectory() as tmp:
            if objects is None:
                tools = make_test_tools(tmp)
                oid = object_id or ("l_tool" if task == "sweeping" else "t_hammer")
                if oid not in tools:
                    raise ValueError(
                        f"without --objects the object is one of {', '.join(tools)}, got '{oid}'"
                    )
                obj = tools[oid]
            else:
                if not object_id:
                    raise ValueError("--object ID is required with --objects")
                obj = load_object(objects, object_id)
            sim = Simulator(cfg, task, obj)
            obs = sim.reset(seed)
            if depth_png is not None:
                from PIL import Image

                d = obs.depth
                lo, hi = np.nanmin(d), np.nanmax(d)
                img = np.nan_to_num((hi - d) / max(hi - lo, 1e-6) * 255, nan=0).astype(np.uint8)
                depth_png.parent.mkdir(parents=True, exist_ok=True)
                Image.fromarray(img).save(depth_png)
                typer.echo(f"depth image -> {depth_png}")
            if grasp is None:
                g = sim.default_grasp()
                typer.echo(
                    f"no --grasp given: using the default grasp at the centre of mass across the narrow "
                    f"side: {g.x:.3f} {g.y:.3f} {g.z:.3f} {g.phi:.3f}"
                )
            else:
                g = Grasp.from_array(grasp)
                half = 0.5 * np.asarray(cfg.world.table_size)
                if abs(g.x) > half[0] or abs(g.y) > half[1]:
                    typer.echo(
                        f"warning: the grasp ({g.x:.3f}, {g.y:.3f}) is off the table top "
                        f"(|x| <= {half[0]:.2f}, |y| <= {half[1]:.2f}); the object lies at "
                        f"{', '.join(f'{v:.3f}' for v in sim.object_pose()[0][:2])}"
                    )
            a = np.zeros(4) if action is None else np.asarray(action, dtype=np.float64)
            recorder = None
            if gif is not None:
                from tognet.sim.render import GifRecorder

                recorder = GifRecorder(sim.model, every=1)  # a frame every 20 ms of sim time, shown at 25 fps
                sim._recorder = recorder
            result = sim.execute(g, a, trial_seed)
            typer.echo(
                f"grasp_success={result.grasp_success} task_success={result.task_success} "
                f"valid={result.valid} failure={result.failure.value}"
            )
            for key, value in result.info.items():
                typer.echo(f"  {key}: {_short(value)}")
            if recorder is not None and gif is not None:
                recorder.save(gif)
                recorder.close()
                typer.echo(f"animation ({len(recorder.frames)} frames captured) -> {gif}")
