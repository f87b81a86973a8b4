"""``tognet plan``: a task-oriented grasp and motion on your own depth image, with a trained TOG-Net."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import typer

from tognet.cli.util import out_file, user_errors
from tognet.robot.names import ARM_BASES, FLOATING, ROBOT_NAMES
from tognet.tasks import TASK_NAMES, check_task_name, reference_points

DEPTH_SUFFIXES = (".png", ".npy", ".npz")
#: The arms ``--robot`` names, as its metavar writes them.
ARMS_METAVAR = "|".join(ARM_BASES)


def _default_bases() -> str:
    """Each arm's default base, for ``--base-pose``'s help: 'sawyer (-0.2, 0.6, 0) yaw -1.571, ...'."""
    return ", ".join(f"{name} ({', '.join(f'{v:g}' for v in base.position)}) yaw {base.yaw:.4g}"
                     for name, base in ARM_BASES.items())


def _vec(values: list[float] | tuple[float, ...], digits: int = 4) -> str:
    return "(" + ", ".join(f"{v:+.{digits}f}" for v in values) + ")"


#: Options of tognet plan, declared here to keep the command readable.
_BAG = typer.Option(
    None, "--bag", help="A ROS 1 bag (.bag) or ROS 2 bag (its folder; sqlite3 or MCAP) to read the depth "
    "image from (pip install 'tognet\\[ros]'), instead of --depth.")
_DEPTH_TOPIC = typer.Option(
    None, "--depth-topic", help="With --bag: the sensor_msgs/Image topic (16UC1 millimetres or 32FC1 "
    "metres).")
_INFO_TOPIC = typer.Option(
    None, "--info-topic", help="With --bag: the sensor_msgs/CameraInfo topic for the intrinsics (else "
    "--intrinsics).")
_AT = typer.Option(
    None, "--at", min=0, help="With --bag: seconds from the bag's start; the depth image nearest to it "
    "(default: the first).")
_RERUN = typer.Option(
    None, "--rerun", help="Write a Rerun recording of the plan here (.rrd; pip install "
    "'tognet\\[rerun]'): the depth as a point cloud, the objects, the candidates by score, the grasp, "
    "the motion, the arm.")
_METHOD = typer.Option(
    None, "--method", help="The method: any a robot can run (TOG-Net+ActionSearch, TOG-Net, "
    "Task_Agn+Trained, Task_Ori+Random, Task_Agn+Random, Antipodal+Random; case-insensitive). Default: "
    "the best whose models are at hand (with the shipped models, TOG-Net+ActionSearch). The Oracle and "
    "the diagnostic rows need the simulator and are refused.")


def _check_outputs(out: Path | None, overlay: Path | None, rerun: Path | None) -> None:
    """Every output path checked before any work (and the rerun extra there when --rerun is given)."""
    _check_output(out, ".json", "--out")
    _check_output(overlay, ".png", "--overlay")
    _check_output(rerun, ".rrd", "--rerun")
    if rerun is not None:
        from tognet.viz.rerun import require_rerun

        require_rerun()


def _check_output(path: Path | None, suffix: str, option: str) -> None:
    if path is not None:
        out_file(path, option, suffix)  # a folder, a wrong suffix, a file above it, a place not writable


@user_errors
def plan_cmd(
    depth: Path | None = typer.Option(
        None, "--depth", help="Depth image: 16-bit .png (millimetres, 0 = no reading), .npy/.npz (float "
        "metres with NaN or 0 holes, or integer millimetres; a table at an implausible distance in that "
        "unit is refused, naming the unit the values look like). Or --bag."),
    intrinsics: Path | None = typer.Option(
        None, "--intrinsics", help="Intrinsics JSON: width, height, fx, fy, cx, cy (pixels); see the README. "
        "With --bag, this or --info-topic."),
    bag: Path | None = _BAG,
    depth_topic: str | None = _DEPTH_TOPIC,
    info_topic: str | None = _INFO_TOPIC,
    at: float | None = _AT,
    task: str = typer.Option(..., "--task", help=f"The task: {', '.join(TASK_NAMES)}."),
    camera_pose: Path | None = typer.Option(
        None, "--camera-pose", help="Camera pose JSON {\"world_from_camera\": 4 x 4} in a frame whose z = 0 "
        "is the table top. Without it the table plane is fitted to the image."),
    method: str | None = _METHOD,
    checkpoint: Path | None = typer.Option(
        None, "--checkpoint", help="A checkpoint of one of the models the method needs (a task's TOG-Net, "
        "its action-search model or the grasp-only model; its kind is read from it; one the method does not "
        "use is refused). The method's other models: the shipped ones. Without --method, the best method "
        "that uses this kind of model."),
    top: int = typer.Option(3, "--top", min=0, help="Alternatives to report beside the chosen grasp."),
    out: Path | None = typer.Option(None, "--out", help="Write the whole plan here (.json)."),
    overlay: Path | None = typer.Option(None, "--overlay",
                                        help="Draw the plan on the depth image here (.png)."),
    rerun: Path | None = _RERUN,
    reference: tuple[float, float, float] | None = typer.Option(
        None, "--reference", metavar="X Y Z", help=f"The task's reference point ({reference_points()}), "
        "world frame with --camera-pose, else table frame: the start pose is then given absolutely too. "
        "Refused far from the table the image shows or beyond the --robot arm's reach (limits in --config)."),
    object_: str | None = typer.Option(
        None, "--object", metavar="INDEX|U,V", help="The object to plan on, when the image shows several: "
        "its index in the plan's list of objects, or a pixel U,V on it. Default: the largest near the "
        "image's centre that looks like something to pick up."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the sampler and the search."),
    config: Path | None = typer.Option(None, "--config", help="UserPlanConfig JSON (defaults otherwise)."),
    robot: str | None = typer.Option(
        None, "--robot", metavar="|".join(ROBOT_NAMES), help="Plan for this arm beside the table, carrying "
        "the simulator's hand (pip install 'tognet\\[robot]'): only grasps and motions it reaches (the "
        "task's motion too when --reference is given), and the joint trajectory in --out's JSON (robot). "
        f"{FLOATING}: as without the option."),
    base_pose: Path | None = typer.Option(
        None, "--base-pose", help="The --robot arm's base: JSON {\"position\": \\[x, y, z], \"yaw\": rad} "
        "(m, in the frame of --reference: the world frame of --camera-pose, else the plan's table frame; "
        f"z = 0 the table top). Default: the arm's own ({_default_bases()} rad)."),
) -> None:
    """Plan a task-oriented grasp and the task's motion on one depth image from your own camera.

    Prints the method, the grasp (table, camera and world frames), the method's own scores (Q_G and Q_T|G,a
    of the chosen action for the action search; Q_G, Q_T|G, Q_T for TOG-Net), the action, alternatives
    (ranked the method's way), timing, and a low-confidence warning where the method's plans of that score
    succeeded less often than not on held-out scenes; with --robot, the arm's trajectory too.
    """
    from tognet.planning.camera import load_camera_pose
    from tognet.planning.user import UserPlanConfig, UserPlanner, parse_object

    choice = parse_object(object_)
    check_task_name(task, what="--task")
    if base_pose is not None and robot in (None, FLOATING):
        raise ValueError(f"--base-pose places the --robot arm: name the arm with --robot {ARMS_METAVAR}")
    _check_outputs(out, overlay, rerun)
    if reference is not None and not all(math.isfinite(v) for v in reference):
        raise ValueError(f"--reference takes 3 finite numbers, got {' '.join(map(str, reference))}")
    source = _source(depth, intrinsics, bag, depth_topic, info_topic, at)
    arm = _arm_config(robot, base_pose)
    cfg = UserPlanConfig.load(config) if config is not None else UserPlanConfig()
    cfg = cfg.replace(top=top, seed=seed)
    pose = load_camera_pose(camera_pose) if camera_pose is not None else None
    # every input checked before the model loads (the reference point against the table: in the plan)
    raw, image, k, pose = _read_image(source, pose, cfg.limits)
    planner = UserPlanner(task, checkpoint, cfg, robot=arm, method=method)
    plan = planner.plan(raw, k, pose, reference=reference, object=choice)  # as read: its unit is judged
    _print_plan(plan, task, out)
    for text in plan.warnings:
        typer.secho(f"warning: {text}", fg=typer.colors.YELLOW, err=True)
    _write_outputs(plan, image, cfg.antipodal.max_width, task, reference, out, overlay, rerun)


def _write_outputs(plan: Any, image: Any, width: float, task: str, reference: Any, out: Path | None,
                   overlay: Path | None, rerun: Path | None) -> None:
    """The plan's JSON (--out), its picture (--overlay) and its recording (--rerun), each whole or not
    at all, and one line naming what was written."""
    from tognet.io import atomic_path, atomic_write_bytes

    written = []
    if out is not None:
        written.append(str(plan.save(out)))
    if overlay is not None:
        from tognet.planning.overlay import render_plan

        written.append(str(atomic_write_bytes(overlay, render_plan(plan, image, width), fsync=False)))
    if rerun is not None:
        from tognet.tasks import get_task
        from tognet.viz.rerun import log_plan

        with atomic_path(rerun) as tmp:
            log_plan(tmp, plan, image, width, get_task(task), reference)
        written.append(str(rerun))
    if written:
        typer.echo("wrote " + ", ".join(written))


def _source(depth: Path | None, intrinsics: Path | None, bag: Path | None, depth_topic: str | None,
            info_topic: str | None, at: float | None) -> dict[str, Any]:
    """Where the image and the intrinsics come from (--depth and --intrinsics, or --bag and its topics),
    checked: one line for a missing, doubled or misplaced option."""
    if (depth is None) == (bag is None):
        raise ValueError("give the depth image as --depth FILE or as --bag BAG --depth-topic TOPIC (one of "
                         "them)")
    if bag is None:
        extra = [o for o, v in (("--depth-topic", depth_topic), ("--info-topic", info_topic), ("--at", at))
                 if v is not None]
        if extra:
            raise ValueError(f"{', '.join(extra)} read(s) a --bag; with --depth give --intrinsics")
        if intrinsics is None:
            raise ValueError("--depth needs --intrinsics FILE (the camera's width, height, fx, fy, cx, cy)")
        assert depth is not None
        if not depth.is_file():
            folder = " (it is a folder)" if depth.is_dir() else ""
            raise FileNotFoundError(f"depth file not found: {depth}{folder}")
        if depth.suffix.lower() not in DEPTH_SUFFIXES:
            raise ValueError(f"--depth {depth}: unsupported file type '{depth.suffix}' (use .png, .npy or "
                             ".npz)")
        return {"depth": depth, "intrinsics": intrinsics}
    if depth_topic is None:
        raise ValueError("--bag needs --depth-topic TOPIC (a sensor_msgs/Image topic of the bag)")
    if (intrinsics is None) == (info_topic is None):
        raise ValueError("with --bag give the intrinsics as --info-topic TOPIC (a sensor_msgs/CameraInfo "
                         "topic) or --intrinsics FILE (one of them)")
    return {"bag": bag, "depth_topic": depth_topic, "info_topic": info_topic, "at": at,
            "intrinsics": intrinsics}


def _read_image(source: dict[str, Any], pose: Any, limits: Any) -> tuple[Any, Any, Any, Any]:
    """The image as given (the --depth file, the bag's array as its message held it), the image (float
    metres, NaN holes), the intrinsics and the pose, from files or a bag, checked."""
    from tognet.planning.camera import load_intrinsics
    from tognet.planning.user import UserPlanner

    if "bag" not in source:
        k = load_intrinsics(source["intrinsics"])
        return (source["depth"], *UserPlanner.read_inputs(source["depth"], k, pose, limits))
    from tognet.planning.bags import read_bag

    frame = read_bag(source["bag"], source["depth_topic"], source["info_topic"], source["at"])
    k = frame.intrinsics if frame.intrinsics is not None else load_intrinsics(source["intrinsics"])
    typer.echo(f"bag: {source['depth_topic']} at {frame.time:.3f} s, {frame.depth.shape[1]} x "
               f"{frame.depth.shape[0]} {frame.depth.dtype}", err=True)
    return (frame.depth, *UserPlanner.read_inputs(frame.depth, k, pose, limits))


def _arm_config(robot: str | None, base_pose: Path | None) -> Any:
    """The SimConfig of the --robot arm (its preset; its base from --base-pose), None without --robot."""
    if robot is None:
        return None
    from tognet.cli.util import robot_config
    from tognet.planning.reach import load_base_pose
    from tognet.sim.config import SimConfig

    position, yaw = load_base_pose(base_pose) if base_pose is not None else (None, None)
    arm = robot_config(SimConfig(), robot)  # the arm's preset; one line without the robot extra
    if base_pose is not None:
        arm = arm.replace(robot=arm.robot.replace(base_position=position, base_yaw=yaw))
    return arm


def _print_plan(plan: Any, task: str, out: Path | None) -> None:
    """What ``tognet plan`` prints about a plan: timing, table, object, grasp, scores, action, the arm."""
    g = plan.grasp
    t = {k_: 1000 * v for k_, v in plan.timing.items()}
    stages = ", ".join(f"{k_} {v:.0f}" for k_, v in t.items() if k_ != "total")
    models = ", ".join(f"{k_} {v}" for k_, v in plan.models.items()) or "no model"
    typer.echo(f"plan for {task} by {plan.method} ({models}): {plan.candidates} candidates, "
               f"{t['total']:.0f} ms ({stages})")
    p = plan.plane
    fit = f" ({100 * p.inliers:.0f} % of the pixels on it, rms {1000 * p.rms:.1f} mm)" if p.fitted else ""
    typer.echo(f"table: {'fitted to the image' if p.fitted else 'from the camera pose'}, the camera "
               f"{p.offset:.3f} m above it, tilted {p.tilt:.1f} deg{fit}")
    obj = plan.object
    typer.echo(f"object #{obj['index']} of {len(plan.objects)}: {obj['area_cm2']:.0f} cm^2, "
               f"{1000 * obj['height_m']:.0f} mm high, at table ({obj['centre_table_m'][0]:.3f}, "
               f"{obj['centre_table_m'][1]:.3f}) m, pixel ({obj['pixel'][0]:.0f}, {obj['pixel'][1]:.0f}): "
               f"{obj['why']}")
    typer.echo(f"grasp, table frame: x y z {_vec(g.table[:3])} m, phi {g.table[3]:.4f} rad")
    typer.echo(f"grasp, camera frame: centre {_vec(g.camera_position)} m, "
               f"jaw axis {_vec(g.camera_jaw_axis, 3)}")
    if g.world is not None:
        typer.echo(f"grasp, world frame: x y z {_vec(g.world[:3])} m, phi {g.world[3]:.4f} rad")
    typer.echo(f"{g.describe_scores()}; the score is {plan.score}")
    a = g.action
    start = (f"reference + {_vec(g.start_offset, 3)} m" if g.start_position is None else
             f"{_vec(g.start_position, 3)} m ({'world' if g.world is not None else 'table'} frame)")
    typer.echo(f"action: a = {_vec(a[:3], 3)} m, a_phi {a[3]:+.3f} rad; start pose {start}, yaw "
               f"{g.start_yaw:+.3f} rad")
    for i, alt in enumerate(plan.alternatives, start=2):
        typer.echo(f"  alternative {i}: table {_vec(alt.table[:3])} m, phi {alt.table[3]:.3f}; "
                   f"{alt.describe_scores()}; "
                   f"action {_vec(alt.action, 3)}")
    if plan.robot is not None:
        r, c = plan.robot, plan.robot.choice
        steps = ", ".join(w["step"].removeprefix("the ") for w in c.waypoints())
        typer.echo(f"arm: {r.arm}, base at {_vec(r.base_position, 3)} m, yaw {r.base_yaw:+.3f} rad "
                   f"({r.frame} frame): {len(c.reach.path.q)} joint waypoints ({steps}), at least "
                   f"{c.reach.path.min_duration:.2f} s at its joints' speed limits"
                   + (f"; {c.dropped.count} of {c.dropped.candidates} candidates beyond its reach"
                      if c.dropped.count else "")
                   + ("; the joint angles in --out's JSON (robot)" if out is None else ""))


def register(app: typer.Typer) -> None:
    """Add ``plan`` to the tognet command."""
    app.command("plan")(plan_cmd)
