"""The evaluation report: ``report.html`` (self-contained: pictures and animations inlined, opens from
disk) and ``report.md`` (the same tables; pictures as files beside it in ``figures/`` and ``gifs/``)."""

from __future__ import annotations

import base64
import datetime
import html
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tognet.evaluate.config import EvalConfig
from tognet.evaluate.kinds import (
    ACTION_SEARCH,
    BOUND,
    GAP_ROWS,
    ORACLE,
    ORACLE_GRASP,
    ORACLE_MOTION,
    REFERENCE,
    SIM_NOTE,
    compared,
    kinds_of,
    may_be_best,
    scene_bound_name,
)
from tognet.evaluate.subsets import breakdown_note, breakdown_title, broken_down, headline, main_subset
from tognet.io import atomic_write_bytes, atomic_write_text
from tognet.objects.record import ObjectRecord

METHOD_NOTES = {
    "Antipodal+Random": "a random NMS mode of the antipodal candidates (ranked by antipodal quality), held "
                        "either way round at random; the baselines' random action (±5 cm, ±π/20 around the "
                        "task's nominal start)",
    "Task_Agn+Random": "CEM on the grasp-only model's Q_G (our stand-in for Dex-Net 2.0's GQ-CNN); random "
                       "action",
    "Task_Agn+Trained": "CEM on Q_G; the task model's action mean at that grasp",
    "Task_Ori+Random": "CEM on the task model's Q_T = Q_T|G · Q_G; random action",
    "TOG-Net": "CEM on Q_T; the task model's action mean (the paper's method)",
    ACTION_SEARCH: "beyond the paper: the action-conditioned model Q_T|G,a (trained on every trial, "
                   "failures included) rates each grasp by the best action it allows, Q_G · max_a "
                   "Q_T|G,a, instead of by the collection policy's action; at the chosen grasp CEM "
                   "searches the action under Q_T|G,a (the <task>_search model)",
    "Oracle": "simulator ground truth: NMS modes held both ways round, each tried in the simulator with "
              "actions computed from the tool's pose in the hand, on execution-noise seeds the evaluation "
              "does not use; an upper bound, not a method a robot could run",
    BOUND: "the stronger bound, simulator ground truth: the Oracle's plan and every method's own plan (and "
           "the learned ones' next grasps) tried in the simulator, ties between plans that won every trial "
           "broken on more trials; then the Oracle's motion from those grasps, a wider Oracle search and "
           "small moves of the best action, on execution-noise seeds the evaluation does not use; the pair "
           "that won most",
    ORACLE_MOTION: "diagnostic, uses the simulator: TOG-Net's grasp (CEM on Q_T), then the Oracle's action "
                   "search from that grasp in the simulator; its gain over TOG-Net is what a perfect "
                   "motion is worth from TOG-Net's grasps",
    ORACLE_GRASP: "diagnostic, uses the simulator: the Oracle's grasp (its whole simulator search), then "
                  "the task model's action mean at it; its gain over TOG-Net is what a perfect grasp is "
                  "worth with TOG-Net's motion",
}


@dataclass
class Table:
    """A table for both outputs: cells are text or (text, css class)."""

    title: str
    header: list[str]
    rows: list[list[Any]] = field(default_factory=list)
    note: str = ""
    wrap: bool = False  # long text cells: left-aligned, wrapped

    def html(self) -> str:
        def cell(c: Any, tag: str) -> str:
            text, cls = (c if isinstance(c, tuple) else (c, ""))
            return f"<{tag}{f' class={cls!r}' if cls else ''}>{html.escape(str(text))}</{tag}>"

        head = "".join(cell(h, "th") for h in self.header)
        body = "".join("<tr>" + "".join(cell(c, "td") for c in row) + "</tr>" for row in self.rows)
        note = f"<p class='note'>{html.escape(self.note)}</p>" if self.note else ""
        title = f"<h3>{html.escape(self.title)}</h3>" if self.title else ""
        return f"<div class='tbl'>{title}<table{' class=wrap' if self.wrap else ''}><tr>{head}</tr>{body}" \
               f"</table>{note}</div>"

    def markdown(self) -> str:
        def text(c: Any) -> str:
            t = str(c[0] if isinstance(c, tuple) else c).replace("|", "\\|")
            return f"**{t}**" if isinstance(c, tuple) and c[1] in ("best", "pos") else t

        lines = [f"### {self.title}", "", "| " + " | ".join(self.header) + " |",
                 "|" + " --- |" * len(self.header)]
        lines += ["| " + " | ".join(text(c) for c in row) + " |" for row in self.rows]
        if self.note:
            lines += ["", self.note]
        return "\n".join(lines) + "\n"


def _pct(x: float | None, digits: int = 1) -> str:
    return "n/a" if x is None else f"{100 * x:.{digits}f}"


def _name(results: dict[str, Any], m: str) -> Any:
    """A method's name cell: a diagnostic's marked as using the simulator (and styled apart)."""
    if kinds_of([m], results.get("kinds"))[m] == "diagnostic":
        return f"{m} †", "diag"
    return m


def _has_diagnostics(results: dict[str, Any]) -> bool:
    return any(k == "diagnostic" for k in kinds_of(results["methods"], results.get("kinds")).values())


def _rate_cell(s: dict[str, Any]) -> str:
    if s["rate"] is None:
        return "n/a (0)"
    return f"{_pct(s['rate'])} [{_pct(s['ci'][0])}, {_pct(s['ci'][1])}] ({s['valid']})"


def success_table(results: dict[str, Any], task: str, sub: str, title: str, grasp: bool = False) -> Table:
    """Methods x categories: task (or grasp) success %, 95 % Wilson interval, valid trials; the best
    method in bold (of the baselines and ours: not the Oracle, not a diagnostic); diagnostics marked."""
    tres = results["tasks"][task]["categories"]
    cats = list(tres)
    table = Table(title, ["method", *cats], note=SIM_NOTE if _has_diagnostics(results) and not grasp else "")
    key = "grasp_rate" if grasp else "rate"
    kinds = results.get("kinds")
    best = {}
    for c in cats:
        rates = {m: s[key] for m, s in tres[c][sub]["methods"].items()
                 if may_be_best(m, kinds) and s[key] is not None}
        best[c] = max(rates.values()) if rates else None
    for m in results["methods"]:
        row: list[Any] = [_name(results, m)]
        for c in cats:
            s = tres[c][sub]["methods"][m]
            if grasp:
                text = "n/a" if s["grasp_rate"] is None else \
                    f"{_pct(s['grasp_rate'])} [{_pct(s['grasp_ci'][0])}, {_pct(s['grasp_ci'][1])}]"
            else:
                text = _rate_cell(s)
            top = may_be_best(m, kinds) and s[key] is not None and best[c] and s[key] == best[c]
            row.append((text, "best") if top else text)
        table.rows.append(row)
    if not grasp and "scene_bound" in tres[cats[0]][sub]:
        table.rows.append([(scene_bound_name(results['methods']), "diag"),
                           *(_rate_cell(tres[c][sub]["scene_bound"]) for c in cats)])
    return table


def paired_table(results: dict[str, Any], task: str, sub: str, first: str = REFERENCE,
                 key: str = "tognet_minus_method") -> Table | None:
    """``first``'s rate minus each other method's (not the diagnostics: they have the gap section), over
    the same scenes, with the 95 % interval (Newcombe); from the subsets' ``key`` (TOG-Net's by default,
    ``action_search_minus_method`` for the learned action search). None when ``first`` was not evaluated."""
    tres = results["tasks"][task]["categories"]
    cats = list(tres)
    if first not in results["methods"]:
        return None
    title = f"{task}: TOG-Net minus method, paired by scene (percentage points)" if first == REFERENCE else \
        f"{task}: {first} minus method, paired, 95 % interval (percentage points)"
    table = Table(title, ["method", *cats],
                  note=f"Positive: {first} succeeds more often. Bold (green): the 95 % interval lies above "
                       f"zero, {first} is better; italic (red): below zero, the method is better. In "
                       "parentheses: the pairs (scenes where both trials are valid).")
    for m in compared(results["methods"], results.get("kinds")):
        if m == first:
            continue
        row: list[Any] = [m]
        for c in cats:
            d = tres[c][sub].get(key, {}).get(m)
            if not d or d["pairs"] == 0:
                row.append("n/a")
                continue
            text = f"{100 * d['difference']:+.1f} [{100 * d['ci'][0]:+.1f}, {100 * d['ci'][1]:+.1f}] " \
                   f"({d['pairs']})"
            row.append((text, "pos") if d["ci"][0] > 0 else (text, "neg") if d["ci"][1] < 0 else text)
        table.rows.append(row)
    return table


def oracle_table(results: dict[str, Any], task: str, sub: str) -> Table | None:
    """Each method's rate as a fraction of the bound's and the scenes it solves that the bound row does not.
    The bound: the scene bound (the bound row or any row solved the scene) where results.json has it, with
    the bound row's share (Oracle+'s, and the Oracle's, for continuity) in brackets; else the bound row's
    (Oracle+ where it was evaluated, else the Oracle)."""
    methods = results["methods"]
    bound = BOUND if BOUND in methods else ORACLE if ORACLE in methods else None
    if bound is None:
        return None
    tres = results["tasks"][task]["categories"]
    cats = list(tres)
    scene = "scene_bound" in tres[cats[0]][sub]
    rows = [m for m in methods if m != bound or scene]
    table = Table(f"{task}: {_share_title(results, bound, scene)}; scenes the method solves that {bound} "
                  "does not, of the paired scenes", ["method", *cats],
                  note=_share_note(results, bound, scene))
    for m in rows:
        cells = [_oracle_cell(tres[c][sub], m, bound, scene, ORACLE in methods) for c in cats]
        table.rows.append([_name(results, m), *cells])
    return table


def _share_title(results: dict[str, Any], bound: str, scene: bool) -> str:
    within = [f"{bound}'s"] + (["the Oracle's"] if bound == BOUND and ORACLE in results["methods"] else [])
    if scene:
        name = scene_bound_name(results["methods"])
        return f"fraction of the bound's success rate ({name}; in brackets, of {' / '.join(within)}) (%)"
    return f"fraction of {bound}'s success rate (%)" + (f" (in brackets, of {within[1]})" if
                                                        len(within) > 1 else "")


def _share_note(results: dict[str, Any], bound: str, scene: bool) -> str:
    note = f"{bound} is beaten where the second figure is above 0: a plan that works existed there and " \
           f"{bound}'s search did not take it."
    if scene:
        note = f"The bound ({scene_bound_name(results['methods'])}): a scene counts as solvable where any " \
               f"row's trial of it succeeded, so no row solves a scene it does not. " + note
    return note


def _oracle_cell(stats: dict[str, Any], method: str, bound: str = ORACLE, scene: bool = False,
                 oracle: bool = False) -> str:
    plus = bound == BOUND
    own = [_pct(stats["bound_fraction" if plus else "oracle_fraction"].get(method), 0)]
    if plus and oracle and method != ORACLE:
        own.append(_pct(stats["oracle_fraction"].get(method), 0))
    if scene:
        share = _pct(stats["scene_bound"]["fraction"].get(method), 0)
        share += "" if method == bound else f" ({' / '.join(own)})"
    else:
        share = own[0] + (f" ({own[1]})" if len(own) > 1 else "")
    if method == bound:
        return f"{share}; the rows add {stats['scene_bound']['added']}"
    beyond = stats.get("beyond_bound" if plus else "beyond_oracle", {}).get(method)  # older results: none
    return share if beyond is None else f"{share}; {beyond['scenes']} of {beyond['pairs']}"


def failure_table(results: dict[str, Any], task: str, sub: str) -> Table:
    """Why trials failed: per method, each failure reason's share of the valid trials (all categories)."""
    tres = results["tasks"][task]["categories"]
    cat = "all" if "all" in tres else next(iter(tres))
    stats = {m: tres[cat][sub]["methods"][m] for m in results["methods"]}
    reasons = Counter()
    for s in stats.values():
        reasons.update(s["failures"])
    cols = [r for r, _ in reasons.most_common()]
    table = Table(f"{task}: outcomes of the valid trials ({cat}; % of each method's trials)",
                  ["method", "success", *cols, "invalid"],
                  note="grasp_failed: not held clear of the table after the lift; dropped: slipped out "
                       "after a good grasp; collision_before_motion: the tool or hand hit a prop on the way; "
                       "missed: never touched the targets; task_failed: touched them, not enough; "
                       "unreachable: the plan lies outside the gripper's travel (an arm: out of its reach); "
                       "joint_limit: an arm reaches it only past a joint's range; no_grasp: no antipodal "
                       "candidate.")
    for m, s in stats.items():
        n = s["valid"] or 1
        table.rows.append([_name(results, m), _pct(s["rate"]),
                           *(_pct(s["failures"].get(r, 0) / n) for r in cols), str(s["invalid"])])
    return table


def subsets_tables(results: dict[str, Any], task: str) -> list[Table]:
    """A task by its subsets of scenes (sweeping: by number of cans), one table per category."""
    tables = []
    for cat, subsets in results["tasks"][task]["categories"].items():
        table = Table(f"{task}, {cat}: task success % [95 % interval] (valid trials)", ["method", *subsets])
        for m in results["methods"]:
            table.rows.append([_name(results, m),
                               *(_rate_cell(subsets[sub]["methods"][m]) for sub in subsets)])
        tables.append(table)
    if tables:
        tables[-1].note = breakdown_note(task)
    return tables


def timing_table(results: dict[str, Any]) -> Table:
    """Mean seconds per stage of planning and of the trial, per task and method."""
    stages = ["depth", "candidates", "grasp", "action", "search", "total", "execute", "search_trials"]
    table = Table("time per episode (ms; search_trials: the Oracle's simulated trials per plan)",
                  ["task", "method", *stages])
    for task, tres in results["tasks"].items():
        for m, t in tres["timing"].items():
            table.rows.append([task, _name(results, m),
                               *("" if k not in t else f"{t[k]:.1f}" if k == "search_trials"
                                 else f"{1000 * t[k]:.0f}" for k in stages)])
    return table


GAP_NOTE = ("Two diagnostic rows (†: they use the simulator's ground truth) split the gap between TOG-Net "
            "and the Oracle into its grasp and its motion. TOG-Net grasp + Oracle motion keeps TOG-Net's "
            "grasp and lets the Oracle search the motion from it: its gain over TOG-Net is what a perfect "
            "motion is worth (the grasp fixed). Oracle grasp + TOG-Net motion takes the Oracle's grasp and "
            "TOG-Net's motion: its gain is what a perfect grasp is worth (the motion fixed). What neither "
            "closes alone needs both.")


def _q(x: float | None) -> str:
    """A Q_T value: two decimals, or one significant digit below 0.01."""
    return "n/a" if x is None else f"{x:.2f}" if x >= 0.01 else f"{x:.1g}"


def _gap_categories(results: dict[str, Any], task: str) -> list[str]:
    sub = main_subset(task)
    tres = results["tasks"][task]["categories"]
    return [c for c in tres if tres[c][sub].get("gap")]


def _gain_cell(gain: float | None, pair: dict[str, Any] | None, share: float | None) -> Any:
    if gain is None:
        return "n/a"
    text = f"{100 * gain:+.1f}"
    if pair and pair["pairs"]:
        text += f" [{100 * pair['ci'][0]:+.1f}, {100 * pair['ci'][1]:+.1f}]"
    if share is not None:
        text += f", {100 * share:.0f} % of the gap"
    if not pair or not pair["pairs"]:
        return text
    return (text, "pos") if pair["ci"][0] > 0 else (text, "neg") if pair["ci"][1] < 0 else text


def gap_tables(results: dict[str, Any], task: str) -> list[Table]:
    """The "where the gap is" tables of a task (main subset), one row per category that has a ``gap``:
    the four rates with their Wilson intervals; the gap and what each half closes alone; how the task
    model rates each method's grasps. Empty when no category has the rows the decomposition needs."""
    sub = main_subset(task)
    tres = results["tasks"][task]["categories"]
    cats = _gap_categories(results, task)
    if not cats:
        return []
    rows = [m for m in GAP_ROWS if m in results["methods"]]
    rates = Table(f"{headline(task)}: task success % [95 % interval] (valid trials)",
                  ["category", *(_label(results, m) for m in rows)])
    for c in cats:
        rates.rows.append([c, *(_rate_cell(tres[c][sub]["methods"][m]) for m in rows)])
    split = Table(f"{task}: the gap to the Oracle, and what each half closes alone (percentage points)",
                  ["category", "gap: Oracle − TOG-Net", "perfect motion (TOG-Net's grasp fixed)",
                   "perfect grasp (TOG-Net's motion fixed)", "needs both"],
                  note="Perfect motion: (TOG-Net grasp + Oracle motion) − TOG-Net; perfect grasp: (Oracle "
                       "grasp + TOG-Net motion) − TOG-Net; each a difference of two rates of the success "
                       "table, in brackets its paired 95 % interval (scenes where both trials are valid), "
                       "and its share of the gap. Needs both: the part of the gap neither half closes alone "
                       "(negative when the two close overlapping parts). Bold: the interval lies above "
                       "zero; italic: below.")
    for c in cats:
        g = tres[c][sub]["gap"]
        motion, grasp = g.get("perfect_motion") or {}, g.get("perfect_grasp") or {}
        both = g.get("needs_both")
        share = both / g["gap"] if both is not None and g["gap"] is not None and g["gap"] > 0 else None
        rest = "n/a" if both is None else f"{100 * both:+.1f}" + \
            (f", {100 * share:.0f} % of the gap" if share is not None else "")
        split.rows.append([c, _gain_cell(g["gap"], g.get("gap_paired"), None),
                           _gain_cell(motion.get("gain"), motion.get("paired"), motion.get("share_of_gap"))
                           if motion else "not evaluated",
                           _gain_cell(grasp.get("gain"), grasp.get("paired"), grasp.get("share_of_gap"))
                           if grasp else "not evaluated",
                           rest])
    tables = [rates, split]
    rated = [m for m in results["methods"] if any(m in tres[c][sub].get("model_rating", {}) for c in cats)]
    if rated:
        rating = Table(f"{task}: how the {task} model rates each method's grasps (Q_T at the chosen grasp: "
                       "median, mean, trials)", ["method", *cats],
                       note=f"{ORACLE_GRASP} holds the Oracle's grasp of the same scene, so its row is how "
                            "the model rates the Oracle's grasps." if ORACLE_GRASP in rated else "")
        for m in rated:
            row: list[Any] = [_name(results, m)]
            for c in cats:
                r = tres[c][sub].get("model_rating", {}).get(m)
                row.append(f"{_q(r['median_q_t'])} ({_q(r['mean_q_t'])}, {r['n']})" if r else "n/a")
            rating.rows.append(row)
        tables.append(rating)
    return tables


def gap_rating_lines(results: dict[str, Any], task: str) -> list[str]:
    """Per category with a gap: how the task model rates the Oracle's grasps against TOG-Net's own."""
    sub = main_subset(task)
    tres = results["tasks"][task]["categories"]
    lines = []
    for c in _gap_categories(results, task):
        rating = tres[c][sub]["gap"].get("model_rating") or {}
        own, oracle = rating.get("tognet") or {}, rating.get("oracle_grasps") or {}
        mine = f"its own (TOG-Net's) at {_q(own['median_q_t'])} (median of {own['n']})" if own.get("n") \
            else "its own: no rating recorded"
        if oracle and oracle["all"]["n"]:
            worked = oracle["worked"]
            extra = f"; {_q(worked['median_q_t'])} for the {worked['n']} that worked" if worked["n"] else ""
            everything = oracle["all"]
            lines.append(f"{c}: the {task} model rates the Oracle's grasps at Q_T "
                         f"{_q(everything['median_q_t'])} (median of {everything['n']}{extra}), {mine}.")
        else:
            lines.append(f"{c}: the Oracle's grasps are not rated (that needs the {ORACLE_GRASP} row); the "
                         f"{task} model rates {mine.removeprefix('its own ')}.")
    return lines


def pick_examples(records: Sequence[dict[str, Any]], task: str, method: str
                  ) -> list[tuple[str, dict[str, Any]]]:
    """A typical success (the first, in job order) and a typical failure (the first with the method's most
    common failure reason) of a method, among valid trials with a plan."""
    rs = [r for r in records if r["task"] == task and r["method"] == method and r["valid"] and r.get("grasp")]
    out = []
    success = next((r for r in rs if r["task_success"]), None)
    if success is not None:
        out.append(("success", success))
    fails = [r for r in rs if not r["task_success"]]
    if fails:
        reason = Counter(r["failure"] for r in fails).most_common(1)[0][0]
        out.append((f"failure: {reason}", next(r for r in fails if r["failure"] == reason)))
    return out


def _data_uri(path: Path) -> str:
    mime = {".png": "image/png", ".gif": "image/gif"}[path.suffix.lower()]
    return f"data:{mime};base64,{base64.b64encode(path.read_bytes()).decode()}"


def _label(results: dict[str, Any], m: str) -> str:
    name = _name(results, m)
    return name[0] if isinstance(name, tuple) else name


def methods_table(results: dict[str, Any], title: str = "") -> Table:
    """What each evaluated method is (diagnostics marked, with the note saying what the mark means)."""
    return Table(title, ["method", "grasp and action"],
                 [[_name(results, m), METHOD_NOTES.get(m, "")] for m in results["methods"]],
                 note=SIM_NOTE if _has_diagnostics(results) else "", wrap=True)


def _chart_note(results: dict[str, Any]) -> str:
    bounds = [m for m in (ORACLE, BOUND) if m in results.get("methods", ())]
    note = "Bars: task success over valid trials; whiskers: 95 % Wilson intervals."
    if bounds:
        note += f" Hatched: {' and '.join(bounds)} (upper bounds, simulator ground truth). Dashed line: " \
                f"the bound, {scene_bound_name(bounds)} (the scenes where any row's trial succeeded)."
    if _has_diagnostics(results):
        note += " The diagnostic rows (†) are not drawn here: they use the simulator, see where the gap is."
    return note


CSS = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:24px auto;max-width:1300px;
color:#222;line-height:1.4;padding:0 16px}
h1{font-size:24px}h2{font-size:19px;border-bottom:1px solid #ddd;padding-bottom:4px;margin-top:34px}
h3{font-size:15px;margin:18px 0 6px}
table{border-collapse:collapse;font-size:12.5px;margin:4px 0}
td,th{border:1px solid #ddd;padding:3px 8px;text-align:right;white-space:nowrap}
td:first-child,th:first-child{text-align:left}th{background:#f4f4f4}
td.best,td.pos{font-weight:bold;background:#eaf6ea}td.neg{font-style:italic;background:#fbeaea}
td.diag{font-style:italic;color:#555}ul.lines{margin:4px 0 8px;font-size:13px}
table.wrap td,table.wrap th{white-space:normal;text-align:left}
.row{display:flex;flex-wrap:wrap;gap:8px 36px;align-items:flex-start}.tbl{max-width:100%}
.tbl .note{max-width:560px}
.note{font-size:12px;color:#555;max-width:1100px}img{max-width:100%}
.gifs{display:grid;grid-template-columns:repeat(auto-fill,minmax(300px,1fr));gap:10px}
figure{margin:0;font-size:11.5px;color:#333}figure img{border:1px solid #ccc}
code{background:#f4f4f4;padding:0 3px}
"""


def write_report(out: Path, results: dict[str, Any], records: Sequence[dict[str, Any]], *,
                 models: dict[str, Path], config: EvalConfig, objects: dict[str, list[ObjectRecord]],
                 run_dir: str | Path | None = None, animations: bool = True, executor: Any = None,
                 log: Callable[[str], None] = print) -> tuple[Path, Path]:
    """Write ``report.html`` and ``report.md`` into ``out`` (figures in ``out/figures``, animations in
    ``out/gifs``, rendered on ``executor``'s workers when one is given); returns both paths."""
    import tognet.evaluate.figures as figures

    fig_dir = out / "figures"
    tasks = list(results["tasks"])
    pictures: dict[str, Path | None] = {
        "results": figures.results_chart(results, fig_dir / "results.png"),
        **{f"subsets-{t}": figures.subsets_chart(results, t, fig_dir / f"{t}_subsets.png")
           for t in broken_down(results)},
        "gap": figures.gap_chart(results, fig_dir / "gap.png"),
    }
    loaded = {}
    if models:
        from tognet.jobs.models import load_model

        loaded = {name: load_model(str(path)) for name, path in models.items()}
    examples = [o for recs in objects.values() for o in recs[:2]][:6]
    pictures["qualitative"] = figures.qualitative_figure(examples, loaded, config,
                                                         fig_dir / "qualitative.png", seed=config.seed)
    run = Path(run_dir) if run_dir else next((r for t in tasks if (r := figures.find_run_dir(models.get(t)))),
                                             None)
    pictures["curves"] = figures.training_curves(run, tasks, fig_dir / "training_curves.png") if run else None
    pictures["learning"] = figures.learning_curve(run, tasks, fig_dir / "learning_curve.png",
                                                  _levels(results)) if run else None
    gifs, gif_note = _animations(out, results, records, objects, config, executor, log) if animations else \
        ({t: [] for t in tasks}, "Animations not made (--no-animations).")
    html_path, md_path = out / "report.html", out / "report.md"
    atomic_write_text(html_path, _html(results, pictures, gifs, gif_note, run))
    atomic_write_text(md_path, _markdown(results, pictures, gifs, gif_note, run, out))
    return html_path, md_path


def _levels(results: dict[str, Any]) -> dict[str, list[tuple[str, float]]]:
    """Per task, the bound's rate (Oracle+, else the Oracle) and the best learned method's on all the test
    scenes, for the learning curves."""
    out: dict[str, list[tuple[str, float]]] = {}
    for task, tres in results["tasks"].items():
        cats = tres["categories"]
        main = cats["all" if "all" in cats else next(iter(cats))][main_subset(task)]
        stats, top = main["methods"], main.get("scene_bound")
        rows = [m for m in (BOUND, ORACLE) if m in stats][:1] + \
            [m for m in (ACTION_SEARCH, REFERENCE) if m in stats][:1]
        out[task] = [(f"{m}, test scenes", stats[m]["rate"]) for m in rows if stats[m]["rate"] is not None]
        if top is not None and top["rate"] is not None:  # the scene bound, above the bound row
            out[task].insert(0, (f"{scene_bound_name(results['methods'])}, test scenes", top["rate"]))
    return out


def _animations(out: Path, results: dict[str, Any], records: Sequence[dict[str, Any]],
                objects: dict[str, list[ObjectRecord]], config: EvalConfig, executor: Any,
                log: Callable[[str], None]) -> tuple[dict[str, list[tuple[str, str, Path, str]]], str]:
    """A typical success and failure of each method per task, animated (GIFs in ``out/gifs``)."""
    from tognet.evaluate.figures import GifJob, run_gif_job
    from tognet.jobs.workers import LocalExecutor

    by_id = {o.object_id: o for recs in objects.values() for o in recs}
    jobs, meta = [], []
    for task in results["tasks"]:
        for m in results["methods"]:
            for kind, r in pick_examples(records, task, m):
                path = out / "gifs" / f"{task}_{m}_{kind.split(':')[0]}.gif".replace("+", "_")
                jobs.append(GifJob(len(jobs), by_id[r["object_id"]], task, r["scene_seed"], tuple(r["grasp"]),
                                   tuple(r["action"]), str(path), config))
                meta.append((task, m, kind, r))
    log(f"animating {len(jobs)} typical episodes for the report")
    outputs: dict[int, Any] = {}
    (executor or LocalExecutor(0)).run(jobs, lambda job, o: outputs.__setitem__(job.index, o), log,
                                       fn=run_gif_job)
    gifs: dict[str, list[tuple[str, str, Path, str]]] = {t: [] for t in results["tasks"]}
    errors = []
    for job, (task, m, kind, r) in zip(jobs, meta, strict=True):
        o = outputs.get(job.index)
        if o is None or o.error:
            errors.append(o.error if o is not None else "not run")
            continue
        rerun = o.stats["failure"]
        atomic_write_bytes(job.path, o.stats["gif"])
        caption = f"{kind} — {r['object_id']}, scene {r['scene_seed']}" + \
            ("" if rerun == r["failure"] else f" (the rendered rerun: {rerun})")
        gifs[task].append((m, kind, Path(job.path), caption))
    note = ""
    if errors:
        note = f"{len(errors)} of {len(jobs)} animations failed: {errors[0]}"
        log(note)
    return gifs, note


def _tables(results: dict[str, Any]) -> list[tuple[str, list[Table]]]:
    sections = []
    for task in results["tasks"]:
        sub = main_subset(task)
        tables = [success_table(results, task, sub, f"{headline(task)}: task success % [95 % interval] "
                                                    "(valid trials)")]
        tables += [t for t in (paired_table(results, task, sub),
                               paired_table(results, task, sub, ACTION_SEARCH, "action_search_minus_method"),
                               oracle_table(results, task, sub)) if t]
        tables.append(success_table(results, task, sub, f"{task}: grasp success % [95 % interval]",
                                    grasp=True))
        tables.append(failure_table(results, task, sub))
        sections.append((task, tables))
    return sections


def _carrier_line(robot: dict[str, Any]) -> str:
    """What carried the hand in the evaluation (``SimConfig.robot``; older results: the floating base)."""
    name = robot.get("name", "floating")
    if name == "floating":
        return "The hand on the floating x, y, z, yaw base (no arm)."
    base = robot.get("base_position")
    where = f"its base at {base}" if base else "at its default base pose"
    return (f"The hand carried by the {name} arm ({where}; its preset, tognet/robot/presets/{name}.json, "
            "on top of the config): joint speed limits, ranges and reach count.")


def _settings_lines(results: dict[str, Any], run: Path | None) -> list[str]:
    s, r = results["settings"], results["run"]
    eps = r.get("episodes_per_s_now")
    lines = [
        f"Tasks {', '.join(s['tasks'])}; {s['episodes']} scenes per task and category, every method on every "
        f"scene (the same object pose, depth image and execution noise: paired comparisons).",
        f"Categories: {', '.join(s['categories'])} (test split: objects never used in training).",
        "Models: " + "; ".join(f"{k} {v['path']} (sha256 {v['sha256']})" for k, v in s["models"].items()),
        f"Config hash {s['config_hash']}; "
        + (f"this run: {r['episodes_run_now']} episodes in {r['seconds_now']:.0f} s"
           + (f" ({eps:.2f} episodes/s on {r['workers']} workers)" if eps else "")
           if r["episodes_run_now"] else "every episode was already there (this run re-rendered the report)")
        + ".",
        _carrier_line(s.get("config", {}).get("sim", {}).get("robot", {})),
        f"Training curves from {run}" if run else "No pipeline run folder given: no training curves.",
    ]
    if r.get("job_errors"):
        lines.append(f"{len(r['job_errors'])} job(s) skipped: {r['job_errors'][:3]}")
    return lines


def _html(results: dict[str, Any], pictures: dict[str, Path | None],
          gifs: dict[str, list[tuple[str, str, Path, str]]], gif_note: str, run: Path | None) -> str:
    def img(key: str, alt: str) -> str:
        p = pictures.get(key)
        return f"<img src='{_data_uri(p)}' alt='{html.escape(alt)}'>" if p else ""

    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>TOG-Net evaluation</title>"
             f"<style>{CSS}</style></head><body>",
             f"<h1>TOG-Net evaluation in simulation</h1><p class='note'>{html.escape(date)}</p><ul>",
             *(f"<li>{html.escape(line)}</li>" for line in _settings_lines(results, run)), "</ul>",
             "<h2>Methods</h2>", methods_table(results).html(),
             "<h2>Task success by category</h2>", img("results", "bar chart of task success"),
             f"<p class='note'>{html.escape(_chart_note(results))}</p>"]
    for task, tables in _tables(results):
        parts.append(f"<h2>{html.escape(task)}</h2><div class='row'>")
        parts += [t.html() for t in tables]
        parts.append("</div>")
    gap_tasks = [t for t in results["tasks"] if _gap_categories(results, t)]
    if gap_tasks:
        parts += ["<h2>Where the gap is: grasp or motion</h2>",
                  f"<p class='note'>{html.escape(GAP_NOTE)}</p>",
                  img("gap", "the gap to the Oracle, grasp and motion")]
        for task in gap_tasks:
            parts.append(f"<h3>{html.escape(task)}</h3><ul class='lines'>")
            parts += [f"<li>{html.escape(line)}</li>" for line in gap_rating_lines(results, task)]
            parts += ["</ul><div class='row'>", *(t.html() for t in gap_tables(results, task)), "</div>"]
    for task in broken_down(results):
        title = breakdown_title(task)
        parts += [f"<h2>{html.escape(title[0].upper() + title[1:])}</h2>", img(f"subsets-{task}", title),
                  "<div class='row'>", *(t.html() for t in subsets_tables(results, task)), "</div>"]
    parts += ["<h2>Where each model grasps</h2>", img("qualitative", "grasps on depth images"),
              "<p class='note'>The same depth image (the object alone on the table) per row: the "
              "task-agnostic grasp (CEM on Q_G), and TOG-Net's grasp for each task evaluated ("
              f"{html.escape(', '.join(results['tasks']))}; CEM on that task's Q_T), with the score each was "
              "chosen by. A white dot marks each finger.</p>"]
    parts.append("<h2>Episodes (GIFs at real speed)</h2>")
    if gif_note:
        parts.append(f"<p class='note'>{html.escape(gif_note)}</p>")
    for task, items in gifs.items():
        if not items:
            continue
        parts.append(f"<h3>{html.escape(task)}</h3><div class='gifs'>")
        parts += [f"<figure><img src='{_data_uri(p)}' alt='{html.escape(m)} {html.escape(kind)}'>"
                  f"<figcaption><b>{html.escape(_label(results, m))}</b> {html.escape(cap)}</figcaption>"
                  "</figure>"
                  for m, kind, p, cap in items]
        parts.append("</div>")
    parts.append("<h2>Training: each self-supervision round</h2>")
    parts.append(img("curves", "training curves") if pictures.get("curves") else
                 "<p class='note'>No pipeline run folder: pass --run RUN_DIR (a `tognet pipeline` "
                 "output).</p>")
    if pictures.get("learning"):
        parts.append("<p>The greedy policy's task success in each round against the trials collected "
                     "before it (the data its model learnt from), with exploration noise:</p>")
        parts.append(img("learning", "learning curve"))
    parts += ["<h2>Time</h2>", timing_table(results).html(), "</body></html>"]
    return "\n".join(parts)


def _markdown(results: dict[str, Any], pictures: dict[str, Path | None],
              gifs: dict[str, list[tuple[str, str, Path, str]]], gif_note: str, run: Path | None,
              out: Path) -> str:
    def img(key: str, alt: str) -> str:
        p = pictures.get(key)
        return f"![{alt}]({p.relative_to(out).as_posix()})\n" if p else ""

    parts = ["# TOG-Net evaluation in simulation", "",
             *(f"- {line}" for line in _settings_lines(results, run)),
             "", methods_table(results, "Methods").markdown(),
             "## Task success by category", "", img("results", "task success by category"), "",
             _chart_note(results), ""]
    for task, tables in _tables(results):
        parts += [f"## {task}", ""] + [t.markdown() for t in tables]
    gap_tasks = [t for t in results["tasks"] if _gap_categories(results, t)]
    if gap_tasks:
        parts += ["## Where the gap is: grasp or motion", "", GAP_NOTE, "",
                  img("gap", "the gap to the Oracle, grasp and motion")]
        for task in gap_tasks:
            parts += [f"### {task}", "", *(f"- {line}" for line in gap_rating_lines(results, task)), ""]
            parts += [t.markdown() for t in gap_tables(results, task)]
    for task in broken_down(results):
        title = breakdown_title(task)
        parts += [f"## {title[0].upper() + title[1:]}", "", img(f"subsets-{task}", title)]
        parts += [t.markdown() for t in subsets_tables(results, task)]
    parts += ["## Where each model grasps", "", img("qualitative", "grasps on depth images")]
    parts += ["## Episodes (GIFs at real speed)", ""] + ([gif_note, ""] if gif_note else [])
    for task, items in gifs.items():
        parts += [f"### {task}", ""] + [f"- **{_label(results, m)}** {cap}: "
                                         f"![{m} {kind}]({p.relative_to(out).as_posix()})"
                                         for m, kind, p, cap in items] + [""]
    parts += ["## Training: each self-supervision round", "",
              img("curves", "training curves") or "No pipeline run folder given.", "",
              img("learning", "learning curve") if pictures.get("learning") else "", "",
              timing_table(results).markdown()]
    return "\n".join(parts) + "\n"
