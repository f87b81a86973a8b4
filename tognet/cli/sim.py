"""``tognet sim``: run one episode and write an animation of it."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Any

import typer

from tognet.cli.util import ROBOT_HELP, out_file, robot_config, user_errors
from tognet.tasks import DEFAULT_TASK, GRASP_ONLY, SIM_TASKS, TASK_NAMES, check_task_name, get_props, get_task


def _short(value: object) -> object:
    """``value`` with its floats (also inside lists) rounded to 4 decimals, for printing."""
    if isinstance(value, float):
        return round(value, 4)
    if isinstance(value, (list, tuple)):
        return [_short(v) for v in value]
    return value


def search_trial(sim: Any, grasp: Any, action: Any, trial_seed: int, tool: str | None,
                 max_trials: int = 12) -> tuple[Any, Any, int, bool]:
    """A (grasp, action) for a first run that shows a success: the given grasp or candidates (a hand-made
    tool's known good grasp first, then the default grasp held either way round), each with the given
    action or the oracle's hand-computed ones (:mod:`tognet.sim.oracle`), tried in the simulator on
    ``trial_seed`` until one succeeds (at most ``max_trials``). Returns (grasp, action, tried, found); not
    found: the first pair tried."""
    import numpy as np

    from tognet.geometry import Grasp
    from tognet.objects.handmade import grasp_on_object
    from tognet.sim.oracle import task_actions

    pairs: list[tuple[Any, Any]] = []
    if grasp is not None:
        grasps = [grasp]
    else:
        grasps = []
        pos, rot = sim.object_pose()
        props = sim.props
        known = (props.demo_grasp,) if tool and tool == props.check_object else ()
        for name in known:
            spec = props.check_grasps[name]
            g = grasp_on_object(pos, rot, spec[0], spec[1])
            grasps.append(g)
            if action is None:
                pairs.append((g, props.check_action(name)))
        d = sim.default_grasp()
        grasps += [d, Grasp(d.x, d.y, d.z, float((d.phi + np.pi) % (2 * np.pi)))]
    for g in grasps:
        if action is not None:
            pairs.append((g, np.asarray(action, dtype=np.float64)))
        else:
            pairs += [(g, a) for a in task_actions(sim, g)]
    tried = 0
    for g, a in pairs[:max_trials]:
        try:
            result = sim.execute(g, a, trial_seed)
        except ValueError:  # out of the gripper's reach
            continue
        tried += 1
        if result.task_success:
            return g, a, tried, True
    return pairs[0][0], pairs[0][1], tried, False


def depth_files(depth_png: Path) -> tuple[Path, Path]:
    """The intrinsics and camera-pose files written beside ``--depth-png`` (``<stem>.intrinsics.json``,
    ``<stem>.pose.json``): what ``tognet plan --intrinsics/--camera-pose`` reads."""
    return (depth_png.with_name(f"{depth_png.stem}.intrinsics.json"),
            depth_png.with_name(f"{depth_png.stem}.pose.json"))


@user_errors
def sim_command(
    task: str = typer.Option(DEFAULT_TASK, help=f"Task: {', '.join(SIM_TASKS)}."),
    object_id: str = typer.Option(
        "", "--object", help="Object id in --objects; without --objects: t_hammer or l_tool (hand-made)."
    ),
    objects: Path | None = typer.Option(None, help="Object set folder (with catalog.json)."),
    grasp: tuple[float, float, float, float] | None = typer.Option(
        None,
        metavar="X Y Z PHI",
        help="Grasp x y z phi (world, m, rad). Default: found by a search (see the description above); "
        "with --task grasping, at the centre of mass across the narrow side.",
    ),
    action: tuple[float, float, float, float] | None = typer.Option(
        None,
        metavar="AX AY AZ APHI",
        help="Action a_x a_y a_z a_phi (m, rad) relative to the task's reference point. Default: found "
        "by a search (see the description above).",
    ),
    seed: int = typer.Option(0, min=0, help="Scene seed (object drop, camera, props)."),
    trial_seed: int = typer.Option(0, min=0, help="Execution-noise seed of the trial."),
    gif: Path | None = typer.Option(None, help="Write an animation of the episode here (.gif; needs "
                                    "MuJoCo's offscreen renderer, EGL on a headless machine)."),
    rerun: Path | None = typer.Option(
        None, "--rerun", help="Write a Rerun recording of the episode here (.rrd; pip install "
        "'tognet\\[rerun]'): the tool, props and gripper over time and the outcome."),
    depth_png: Path | None = typer.Option(
        None, help="Write the depth image here as a 16-bit PNG in millimetres, with "
        "<stem>.intrinsics.json and <stem>.pose.json beside it: what `tognet plan` reads."),
    config: Path | None = typer.Option(None, help="SimConfig JSON (default: built-in)."),
    robot: str | None = typer.Option(None, "--robot", help=ROBOT_HELP),
) -> None:
    """Run one episode (drop, depth image, grasp, lift, task primitive), print the labels, animate it.

    Without --grasp and --action, (grasp, action) pairs are tried on the trial seed until one succeeds
    (at most 12): a hand-made tool's known good grasp first, then the default grasp (centre of mass,
    across the narrow side) held either way round, each with the hand-computed actions of
    tognet.sim.oracle; the first that succeeds is shown (or the first tried, if none does). With only
    one of them given, the other is searched so.

    Prints the grasp, the action, the labels (grasp_success, task_success, valid, failure) and the
    episode's measurements. --depth-png also writes <stem>.intrinsics.json and <stem>.pose.json beside
    the PNG, which `tognet plan` and `tognet grasps` read.
    """
    from tognet.sim import SimConfig, Simulator

    _check_inputs(task, grasp, action, gif, depth_png, rerun)
    cfg = robot_config(SimConfig.load(config) if config else SimConfig(), robot)
    if gif is not None:
        from tognet.sim.render import check_renderer

        check_renderer()
    with tempfile.TemporaryDirectory() as tmp:
        obj = _the_object(task, object_id, objects, tmp)
        sim = Simulator(cfg, task, obj)
        recorder = None
        if gif is not None:
            from tognet.sim.render import GifRecorder

            recorder = GifRecorder(sim.model, every=1)  # a frame every 20 ms of sim time, shown at 25 fps
        obs = sim.reset(seed)
        if depth_png is not None:
            _write_depth(depth_png, obs, task)
        g, a = _grasp_and_action(sim, cfg, task, grasp, action, trial_seed, obj.object_id if objects is None
                                 else None)
        result, trace = _run(sim, g, a, trial_seed, recorder, rerun is not None)
        typer.echo(
            f"grasp_success={result.grasp_success} task_success={result.task_success} "
            f"valid={result.valid} failure={result.failure.value}"
        )
        for key, value in result.info.items():
            typer.echo(f"  {key}: {_short(value)}")
        _save_episode(recorder, gif, trace, rerun, result, g.as_array(), a)


def _save_episode(recorder: Any, gif: Path | None, trace: Any, rerun: Path | None, result: Any, grasp: Any,
                  action: Any) -> None:
    """The episode's animation (--gif) and recording (--rerun), each said in one line."""
    if recorder is not None and gif is not None:
        recorder.save(gif)
        recorder.close()
        typer.echo(f"animation ({len(recorder.frames)} frames captured) -> {gif}")
    if trace is not None and rerun is not None:
        from tognet.io import atomic_path
        from tognet.viz.rerun import log_episode

        with atomic_path(rerun) as path:
            log_episode(path, trace, result, grasp, action)
        typer.echo(f"recording ({len(trace.times)} poses of {len(trace.bodies)} bodies) -> {rerun}")


def _run(sim: Any, grasp: Any, action: Any, seed: int, recorder: Any, trace: bool) -> tuple[Any, Any]:
    """The trial, with the GIF's recorder and (``trace``) a pose trace attached: (result, the trace)."""
    from tognet.sim.trace import PoseTrace

    poses = PoseTrace(sim) if trace else None
    hooks = [h for h in (recorder, poses) if h is not None]

    def record(s: Any) -> None:
        for hook in hooks:
            hook(s)

    if not hooks:
        return sim.execute(grasp, action, seed), None
    with sim.recording(record):
        return sim.execute(grasp, action, seed), poses


def _check_inputs(task: str, grasp: Any, action: Any, gif: Path | None, depth_png: Path | None,
                  rerun: Path | None = None) -> None:
    """Refuse, before the episode runs, what cannot work: an unknown task, non-finite numbers, an action
    for the grasp-only task, output paths that cannot be written, --rerun without its extra."""
    if rerun is not None:
        from tognet.viz.rerun import require_rerun

        out_file(rerun, "--rerun", ".rrd")
        require_rerun()
    check_task_name(task, SIM_TASKS, "--task")
    for values, name in ((grasp, "--grasp"), (action, "--action")):
        if values is not None and not all(math.isfinite(v) for v in values):
            raise ValueError(f"{name} takes 4 finite numbers, got {' '.join(map(str, values))}")
    if task == GRASP_ONLY and action is not None:
        raise ValueError(f"--action has no use with --task {GRASP_ONLY} (the episode ends at the lift)")
    if gif is not None:
        out_file(gif, "--gif", ".gif")
    if depth_png is not None:
        out_file(depth_png, "--depth-png", ".png")
        for sibling in depth_files(depth_png):
            out_file(sibling, "--depth-png")


def _the_object(task: str, object_id: str, objects: Path | None, tmp: str) -> Any:
    """The object of the episode: ``object_id`` in ``objects``, or a hand-made tool (by default the one
    the task's scripted checks use) made in ``tmp``."""
    from tognet.objects import load_object
    from tognet.objects.handmade import make_test_tools

    if objects is not None:
        if not object_id:
            raise ValueError("--object ID is required with --objects")
        return load_object(objects, object_id)
    tools = make_test_tools(tmp)
    oid = object_id or (get_props(get_task(task)).check_object if task in TASK_NAMES else "t_hammer")
    if oid not in tools:
        raise ValueError(f"without --objects the object is one of {', '.join(tools)}, got '{oid}'")
    return tools[oid]


def _write_depth(depth_png: Path, obs: Any, task: str) -> None:
    """The depth image as a 16-bit PNG (mm) with its intrinsics and pose files, as ``tognet plan`` reads."""
    from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics

    intr, pose = depth_files(depth_png)
    save_depth_png(depth_png, obs.depth)
    save_intrinsics(intr, obs.camera.intrinsics)
    save_camera_pose(pose, obs.camera.pose)
    typer.echo(f"depth image (16-bit millimetres) -> {depth_png}, intrinsics -> {intr}, camera "
               f"pose -> {pose}; plan on it: tognet plan --depth {depth_png} --intrinsics {intr} "
               f"--camera-pose {pose} --task {task if task in TASK_NAMES else DEFAULT_TASK}")


def _grasp_and_action(sim: Any, cfg: Any, task: str, grasp: Any, action: Any, trial_seed: int,
                      tool: str | None) -> tuple[Any, Any]:
    """The grasp and action to run: as given, else searched (:func:`search_trial`); printed."""
    import numpy as np

    from tognet.geometry import Grasp

    g = None
    if grasp is not None:
        g = Grasp.from_array(grasp)
        half = 0.5 * np.asarray(cfg.world.table_size)
        if abs(g.x) > half[0] or abs(g.y) > half[1]:
            typer.echo(
                f"warning: the grasp ({g.x:.3f}, {g.y:.3f}) is off the table top "
                f"(|x| <= {half[0]:.2f}, |y| <= {half[1]:.2f}); the object lies at "
                f"{', '.join(f'{v:.3f}' for v in sim.object_pose()[0][:2])}"
            )
    if task == GRASP_ONLY:
        g = sim.default_grasp() if g is None else g
        a = np.zeros(4)
        if grasp is None:
            typer.echo("no --grasp given: the default grasp at the centre of mass, across the narrow side")
    elif grasp is None or action is None:
        g, a, tried, found = search_trial(sim, g, action, trial_seed, tool)
        given = "--grasp and --action" if grasp is None and action is None else \
            ("--grasp" if grasp is None else "--action")
        typer.echo(f"no {given} given: tried {tried} (grasp, action) pair(s) from the hand-computed "
                   f"oracle (tognet.sim.oracle); " + ("showing the first that succeeded" if found else
                                                     "none succeeded, showing the first"))
    else:
        a = np.asarray(action, dtype=np.float64)
    typer.echo(f"grasp:  {g.x:.4f} {g.y:.4f} {g.z:.4f} {g.phi:.4f}  (x y z m, phi rad; world frame)")
    if task != GRASP_ONLY:
        typer.echo(f"action: {a[0]:.4f} {a[1]:.4f} {a[2]:.4f} {a[3]:.4f}  (a_x a_y a_z m, a_phi rad; "
                   "relative to the task's reference point)")
    return g, a


def register(app: typer.Typer) -> None:
    """Add the ``sim`` command to the tognet app."""
    app.command("sim")(sim_command)
