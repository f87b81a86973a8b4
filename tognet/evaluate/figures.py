"""The report's pictures: the results bar chart, sweeping by can count, where the gap to the Oracle is
(the diagnostic rows), the qualitative grasps, episode animations and the training curves of each
self-supervision round."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tognet.evaluate.config import EvalConfig
from tognet.evaluate.kinds import (
    BOUND,
    GAP_ROWS,
    ORACLE,
    ORACLE_GRASP,
    ORACLE_MOTION,
    compared,
    kinds_of,
    scene_bound_name,
)
from tognet.evaluate.subsets import breakdown_title, headline, main_subset
from tognet.io import atomic_path
from tognet.jobs.output import JobOutput
from tognet.objects.record import ObjectRecord

#: A colour per method (baselines cool and pale, ours strong, the Oracle dark and hatched; the diagnostics,
#: half TOG-Net and half Oracle, pale with a hatch of the other half's colour).
COLOURS = {
    "Antipodal+Random": "#9e9e9e",
    "Task_Agn+Random": "#9ecae1",
    "Task_Agn+Trained": "#3182bd",
    "Task_Ori+Random": "#fdae6b",
    "TOG-Net": "#d94801",
    "TOG-Net+ActionSearch": "#6a3d9a",
    "TOG-Net+Twin": "#1b9e77",
    ORACLE: "#404040",
    BOUND: "#000000",
    ORACLE_MOTION: "#fdd0a2",
    ORACLE_GRASP: "#bdbdbd",
}
#: (edge colour, hatch) of the bars that are not plain: the Oracle and the diagnostics.
HATCHES = {ORACLE: ("black", "//"), BOUND: ("#808080", "xx"), ORACLE_MOTION: ("#404040", "//"),
           ORACLE_GRASP: ("#d94801", "..")}


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _bars(ax: Any, groups: Sequence[str], methods: Sequence[str], cell: Any, title: str,
          values: bool = False) -> None:
    """Grouped bars: one group per entry of ``groups``, one bar per method; ``cell(group, method)`` gives
    (rate, (low, high), valid) or None; ``values``: each bar's rate written above it."""
    width = 0.8 / max(1, len(methods))
    x = np.arange(len(groups))
    for i, m in enumerate(methods):
        rates, lo, hi = [], [], []
        for g in groups:
            c = cell(g, m)
            r = c[0] if c and c[0] is not None else np.nan
            rates.append(100 * r)
            lo.append(100 * (r - c[1][0]) if c and c[0] is not None else 0)
            hi.append(100 * (c[1][1] - r) if c and c[0] is not None else 0)
        edge, hatch = HATCHES.get(m, ("white", None))
        xs = x + (i - (len(methods) - 1) / 2) * width
        ax.bar(xs, rates, width, yerr=[lo, hi], capsize=2, color=COLOURS.get(m, "#888888"), edgecolor=edge,
               hatch=hatch, label=m, error_kw={"elinewidth": 0.8})
        if values:  # above the whisker
            for xi, r, up in zip(xs, rates, hi, strict=True):
                if not np.isnan(r):
                    ax.text(xi, r + up + 1, f"{r:.0f}", ha="center", va="bottom", fontsize=7)
    ax.set_xticks(x, groups)
    ax.set_ylim(0, 109 if values else 100)
    ax.set_yticks(np.arange(0, 101, 20))
    ax.set_ylabel("task success (%)")
    ax.set_title(title)
    ax.grid(axis="y", alpha=0.3)
    ax.set_axisbelow(True)


def results_chart(results: dict[str, Any], path: Path) -> Path:
    """The paper's simulation figure: per task, success rate by category and method, 95 % intervals."""
    plt = _plt()
    tasks = list(results["tasks"])
    cats = [c for c in results["categories"] if c != "all"]
    methods = compared(results["methods"], results.get("kinds"))  # the diagnostics: gap_chart
    per_task = max(5.0, 0.3 * len(cats) * len(methods) + 1.5)
    fig, axes = plt.subplots(1, len(tasks), figsize=(per_task * len(tasks), 4.2), squeeze=False)
    for ax, task in zip(axes[0], tasks, strict=True):
        sub = main_subset(task)

        def cell(cat: str, m: str, task: str = task, sub: str = sub) -> Any:
            s = results["tasks"][task]["categories"][cat][sub]["methods"][m]
            return s["rate"], s["ci"], s["valid"]

        _bars(ax, cats, methods, cell, headline(task))
        tres = results["tasks"][task]["categories"]
        _scene_bound_ticks(ax, [tres[c][sub].get("scene_bound") for c in cats],
                           scene_bound_name(results["methods"]))
    handles, labels = axes[0][0].get_legend_handles_labels()
    # One row of labels when the figure is wide enough for them (about 1.4 in each), else two rows.
    rows = 1 if per_task * len(tasks) >= 1.4 * len(handles) else 2
    fig.legend(handles, labels, loc="lower center", ncols=-(-len(handles) // rows), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07 * rows, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def _scene_bound_ticks(ax: Any, bounds: Sequence[dict[str, Any] | None], label: str) -> None:
    """The scene bound of each group (:func:`tognet.evaluate.harness.scene_bound`) as a dashed line across
    its bars; nothing for results without it."""
    drawn = False
    for i, b in enumerate(bounds):
        if b is not None and b.get("rate") is not None:
            ax.hlines(100 * b["rate"], i - 0.42, i + 0.42, colors="black", linestyles="--", linewidth=1.2,
                      label=None if drawn else f"bound: {label}", zorder=5)
            drawn = True


def subsets_chart(results: dict[str, Any], task: str, path: Path) -> Path:
    """A task by its subsets of scenes (sweeping: one can, two cans, the mix), all categories together."""
    plt = _plt()
    cats = results["categories"]
    cat = "all" if "all" in cats else cats[0]
    tres = results["tasks"][task]["categories"][cat]
    subsets = list(tres)

    def cell(sub: str, m: str) -> Any:
        s = tres[sub]["methods"][m]
        return s["rate"], s["ci"], s["valid"]

    fig, ax = plt.subplots(figsize=(8.5, 4.0))
    _bars(ax, subsets, compared(results["methods"], results.get("kinds")), cell,
          f"{breakdown_title(task)} ({cat})")
    if ax.get_legend_handles_labels()[0]:  # none when only diagnostic rows were evaluated
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def gap_chart(results: dict[str, Any], path: Path) -> Path | None:
    """Where the gap to the Oracle is: per task, by category, TOG-Net, TOG-Net's grasp with the Oracle's
    motion, the Oracle's grasp with TOG-Net's motion and the Oracle (95 % intervals, rates written on the
    bars). None when no task has the rows the decomposition needs (TOG-Net, the Oracle, a diagnostic)."""
    tasks = [t for t in results["tasks"] if any(subs[main_subset(t)].get("gap")
                                                for subs in results["tasks"][t]["categories"].values())]
    if not tasks:
        return None
    plt = _plt()
    kinds = kinds_of(results["methods"], results.get("kinds"))
    methods = [m for m in GAP_ROWS if m in kinds]
    cats = [c for c in results["categories"] if c != "all"] or list(results["categories"])
    per_task = max(3.6, 0.32 * len(cats) * len(methods) + 1.2)
    width = max(5.6, per_task * len(tasks))  # room for two columns of labels at least
    fig, axes = plt.subplots(1, len(tasks), figsize=(width, 3.6), squeeze=False)
    for ax, task in zip(axes[0], tasks, strict=True):
        sub = main_subset(task)

        def cell(cat: str, m: str, task: str = task, sub: str = sub) -> Any:
            s = results["tasks"][task]["categories"][cat][sub]["methods"][m]
            return s["rate"], s["ci"], s["valid"]

        _bars(ax, cats, methods, cell, headline(task), values=True)
    handles, labels = axes[0][0].get_legend_handles_labels()
    labels = [f"{m} †" if kinds[m] == "diagnostic" else m for m in labels]
    rows = 1 if width >= 2.4 * len(methods) else -(-len(methods) // 2)  # a label needs about 2.4 in
    fig.legend(handles, labels, loc="lower center", ncols=-(-len(methods) // rows), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.08 * rows, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def qualitative_figure(objects: Sequence[ObjectRecord], models: dict[str, Any], config: EvalConfig,
                       path: Path, seed: int = 0) -> Path | None:
    """For each object, one depth image (the object alone on the table) with the task-agnostic grasp (CEM on
    the grasp-only model's Q_G) and each task's TOG-Net grasp (CEM on its Q_T) drawn on it; the same
    antipodal candidates start every search. ``models``: loaded predictors by name (``grasping`` and
    the registered tasks'; those present are drawn)."""
    from tognet.grasping.antipodal import sample_antipodal
    from tognet.grasping.depth import prepare_depth
    from tognet.grasping.draw import depth_to_rgb, jaw_endpoints
    from tognet.policies.grasp import CEMGrasp
    from tognet.policies.view import SceneView
    from tognet.sim import SimulationError, Simulator
    from tognet.tasks import GRASP_ONLY, TASK_NAMES

    columns = [(n, label, "grasp" if n == GRASP_ONLY else "task") for n, label in
               ((GRASP_ONLY, "task-agnostic (Q_G)"), *((t, f"{t} (Q_T)") for t in TASK_NAMES)) if n in models]
    if not columns or not objects:
        return None
    from tognet.grasping.crops import resolve_crop

    crop = resolve_crop(models.values())
    rows = []
    for obj in objects:
        try:
            sim = Simulator(config.sim, GRASP_ONLY, obj)
            obs = sim.reset(seed)
        except SimulationError:
            continue
        scene = prepare_depth(obs.depth, obs.camera)
        cands = sample_antipodal(scene, None, config.plan.antipodal, np.random.default_rng(seed))
        if len(cands) == 0:
            continue
        view = SceneView(scene, cands, None, crop)
        grasps = []
        for name, _label, kind in columns:
            best, score = CEMGrasp(config.plan.policy, models[name], kind=kind).best(
                view, np.random.default_rng([seed, 1]))
            grasps.append((best, score))
        rows.append((obj, obs, cands, grasps))
    if not rows:
        return None
    plt = _plt()
    per_row = 2 if len(rows) > 2 else 1  # objects side by side
    n_rows = -(-len(rows) // per_row)
    fig, axes = plt.subplots(n_rows, per_row * len(columns), figsize=(2.5 * per_row * len(columns),
                                                                      2.45 * n_rows), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    palette = ("#3182bd", "#d94801", "#31a354", "#756bb1", "#e7298a", "#66a61e")  # grasping, then tasks
    colours = {n: palette[i % len(palette)] for i, n in enumerate((GRASP_ONLY, *TASK_NAMES))}
    for k, (obj, obs, cands, grasps) in enumerate(rows):
        r, first = divmod(k, per_row)
        rgb = depth_to_rgb(obs.depth)
        u, v = cands.pixels[:, 0], cands.pixels[:, 1]
        half = max(45.0, 0.6 * max(np.ptp(u), np.ptp(v)) + 25)
        cu, cv = 0.5 * (u.min() + u.max()), 0.5 * (v.min() + v.max())
        box = (max(0, int(cu - half)), min(rgb.shape[1], int(cu + half)),
               max(0, int(cv - half)), min(rgb.shape[0], int(cv + half)))
        for c, ((name, label, _kind), (g, score)) in enumerate(zip(columns, grasps, strict=True)):
            ax = axes[r][first * len(columns) + c]
            ax.axis("on")
            ax.imshow(rgb[box[2]:box[3], box[0]:box[1]], extent=(box[0], box[1], box[3], box[2]))
            (u0, v0), (u1, v1) = jaw_endpoints(obs.camera, g[None], np.array([0.07]))[0]
            ax.plot([u0, u1], [v0, v1], "-", color=colours[name], lw=3)
            ax.plot([u0, u1], [v0, v1], "o", color="white", ms=5, mec=colours[name], mew=2)
            ax.set_xlim(box[0], box[1])
            ax.set_ylim(box[3], box[2])
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"{label} {score:.2f}", fontsize=7.5)
            if c == 0:
                ax.set_ylabel(obj.object_id, fontsize=7.5)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
    return path


def animate_episode(config: EvalConfig, task: str, obj: ObjectRecord, scene_seed: int,
                    grasp: Sequence[float], action: Sequence[float], path: Path,
                    size: tuple[int, int] = (256, 192)) -> tuple[Path, Any]:
    """Run one evaluation episode again with the renderer attached and write it as a GIF that plays at the
    real speed (a frame per 50 ms of simulated time at most); returns the path and the rerun's TrialResult
    (with the renderer attached the cans stay in the full model, so a rare outcome can differ from the
    unrendered trial's)."""
    from tognet.geometry import Grasp
    from tognet.sim import Simulator
    from tognet.sim.render import GifRecorder

    sim = Simulator(config.sim, task, obj)
    sim.reset(scene_seed)
    recorder = GifRecorder(sim.model, width=size[0], height=size[1], every=1, lookat=(0.0, 0.05, 0.0),
                           distance=1.35, azimuth=90.0, elevation=-45.0, max_fps=20)
    try:
        with sim.recording(recorder):
            result = sim.execute(Grasp.from_array(np.asarray(grasp, dtype=np.float64)),
                                 np.asarray(action, dtype=np.float64), seed=config.trial_seed)
        recorder.save(path, fps=20, max_frames=90)
    finally:
        recorder.close()
    return path, result


@dataclass(frozen=True)
class GifJob:
    """One episode to animate, as a job for :mod:`tognet.jobs`' executors (``index`` and ``obj``)."""

    index: int
    obj: ObjectRecord
    task: str
    scene_seed: int
    grasp: tuple[float, ...]
    action: tuple[float, ...]
    path: str  #: where the coordinator writes the GIF
    config: EvalConfig


def run_gif_job(job: GifJob) -> JobOutput:
    """Animate one episode in a worker; the GIF's bytes and the rerun's failure reason in ``stats`` (the
    coordinator writes the file: a cluster node need not see the report's folder), or the error."""
    import tempfile

    try:
        with tempfile.TemporaryDirectory(prefix="tognet-gif-") as tmp:
            gif, result = animate_episode(job.config, job.task, job.obj, job.scene_seed, job.grasp,
                                          job.action, Path(tmp) / Path(job.path).name)
            data = gif.read_bytes()
    except Exception as exc:  # no GL backend, a bad object: the report says so and goes on
        return JobOutput(job.index, {}, {}, error=f"{type(exc).__name__}: {exc}")
    return JobOutput(job.index, {}, {"failure": result.failure.value, "gif": data})


def find_run_dir(task_model: Path | None) -> Path | None:
    """The pipeline run a task model lies in (``RUN/<task>/round<k>/model/best.pt``), if it does."""
    if task_model is None:
        return None
    parents = Path(task_model).resolve().parents
    if len(parents) > 3 and (parents[3] / "preset.json").is_file():
        return parents[3]
    return None


def training_curves(run_dir: Path, tasks: Sequence[str], path: Path) -> Path | None:
    """Per task, the held-out loss and AUCs of each round's training, rounds one after another (dashed
    lines between rounds), from the run's ``<task>/round<k>/model/metrics.json``."""
    series = {}
    for task in tasks:
        rounds = sorted((run_dir / task).glob("round*/model/metrics.json"),
                        key=lambda p: int(p.parent.parent.name.removeprefix("round")))
        hist = []
        for k, file in enumerate(rounds, start=1):
            for h in json.loads(file.read_text()).get("history", []):
                hist.append((k, h))
        if hist:
            series[task] = hist
    if not series:
        return None
    plt = _plt()
    fig, axes = plt.subplots(len(series), 2, figsize=(10, 3.0 * len(series)), squeeze=False)
    for row, (task, hist) in enumerate(series.items()):
        from matplotlib.ticker import MaxNLocator

        x = np.arange(1, len(hist) + 1)
        ax_l, ax_a = axes[row]
        for key, style in (("loss", "-"), ("grasp", "--"), ("task", "-."), ("action", ":")):
            ax_l.plot(x, [h["val"].get(key, np.nan) if h.get("val") else np.nan for _, h in hist], style,
                      label=f"val {key}")
        for head, style in (("grasp", "--"), ("task_given_grasp", "-."), ("task", "-")):
            vals = [((h.get("val") or {}).get("metrics", {}).get(head) or {}).get("auc") for _, h in hist]
            ax_a.plot(x, [np.nan if v is None else v for v in vals], style, label=f"AUC {head}")
        for ax in (ax_l, ax_a):
            for i in range(1, len(hist)):
                if hist[i][0] != hist[i - 1][0]:
                    ax.axvline(i + 0.5, color="grey", ls="--", lw=0.8)
            ax.set_xlabel("epoch (rounds one after another)")
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        ax_l.set_title(f"{task}: held-out loss per round")
        ax_a.set_title(f"{task}: held-out AUC per round")
        ax_a.set_ylim(0.4, 1.0)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
    return path


#: The greedy trials of an epsilon-greedy round, by (grasp source + action source): the paper's TOG-Net
#: (CEM grasp, the policy's action) and the learned action search (its grasp, its action).
GREEDY_SOURCES = ("cem+policy", "search+search")


def round_summaries(run_dir: Path, task: str) -> list[dict[str, Any]]:
    """The collection summaries of a run's rounds for ``task``, in order
    (``<task>/round<k>/data/summary.json`` or ``<task>/round<k>/summary.json``)."""
    found: dict[int, Path] = {}
    for pattern in ("round*/data/summary.json", "round*/summary.json"):
        for file in (run_dir / task).glob(pattern):
            name = file.parent.parent.name if file.parent.name == "data" else file.parent.name
            digits = name.removeprefix("round")
            if digits.isdigit():
                found.setdefault(int(digits), file)
    return [json.loads(found[k].read_text()) for k in sorted(found)]


def learning_curve(run_dir: Path, tasks: Sequence[str], path: Path,
                   levels: dict[str, list[tuple[str, float]]] | None = None) -> Path | None:
    """Per task, the greedy policy's task success in each round against the trials collected before it
    (the data its model was trained on), beside the round's overall task success: whether more data is
    still paying. From the rounds' collection summaries; None when no round has greedy trials.

    ``levels``: per task, (label, rate) drawn across the panel, e.g. the bound's and the evaluated
    method's rates on the test scenes: how far the curve is from what is possible."""
    series = {}
    for task in tasks:
        seen, points = 0, []
        for summary in round_summaries(run_dir, task):
            greedy = [summary.get("by_source", {}).get(k) for k in GREEDY_SOURCES]
            greedy = [g for g in greedy if g and g.get("episodes")]
            rate = (sum(g["task_success"] for g in greedy) / sum(g["episodes"] for g in greedy)
                    if greedy else None)
            points.append((seen, rate, summary.get("task_success_rate")))
            seen += int(summary.get("episodes", 0))
        if any(r is not None for _, r, _ in points):
            series[task] = points
    if not series:
        return None
    plt = _plt()
    fig, axes = plt.subplots(1, len(series), figsize=(4.2 * len(series), 3.2), squeeze=False)
    for ax, (task, points) in zip(axes[0], series.items(), strict=True):
        x = [s / 1000 for s, _, _ in points]
        ax.plot(x, [100 * r if r is not None else np.nan for _, r, _ in points], "o-", color="#6a3d9a",
                label="greedy trials")
        ax.plot(x, [100 * a if a is not None else np.nan for _, _, a in points], "s--", color="#888888",
                label="all trials of the round")
        for (label, rate), style in zip((levels or {}).get(task, []), ("-", ":", "-."), strict=False):
            ax.axhline(100 * rate, color="black", linestyle=style, linewidth=1,
                       label=f"{label} {100 * rate:.0f} %")
        ax.set_xlabel("trials collected before the round (thousands)")
        ax.set_ylabel("task success (%)")
        ax.set_title(f"{task}: learning curve")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
    return path
