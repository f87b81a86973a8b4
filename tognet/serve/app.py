"""The planning service: ``tognet plan`` over HTTP, its models loaded once and kept (FastAPI on uvicorn).

    POST /plan      multipart form: ``depth`` (a 16-bit PNG in millimetres or .npy/.npz bytes) and
                    ``intrinsics`` (JSON), optionally ``camera_pose`` (JSON 4 x 4 world_from_camera),
                    ``task``, ``method``, ``object`` (index or "u,v"), ``reference`` ("x,y,z"), ``robot``,
                    ``base_pose`` (JSON), ``top``, ``seed``; answers the JSON of ``tognet plan --out``
    GET  /health    alive, uptime, requests served, the planners loaded
    GET  /methods   the tasks, the methods a robot can run with their models, each task's default
    GET  /docs      the OpenAPI page

Every plan goes through :class:`tognet.planning.user.UserPlanner`, the same path as ``tognet plan`` and
``tognet.plan``. Plans run on a small pool of threads (``ServeConfig.threads``), each with its own
planners (an arm's reach check keeps state) and torch on one thread per plan; the event loop only reads
requests and writes answers, so a slow client holds up nobody. A bad request is one line of JSON,
``{"error": "..."}``, with a 4xx status (413 for a request or image over the limits, 422 for a plan that
cannot be made on the image, 504 past the time limit); anything else is a 500 with one line, and the
service goes on serving.
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import HTMLResponse, JSONResponse
from starlette.exceptions import HTTPException

from tognet.config import Config, doc
from tognet.errors import TognetError


class RequestError(TognetError):
    """A request the service cannot plan on; ``status`` is the HTTP status it answers with."""

    def __init__(self, message: str, status: int = 400) -> None:
        super().__init__(message)
        self.status = status


@dataclass(frozen=True)
class ServeConfig(Config):
    """How ``tognet serve`` runs (saved nowhere: printed at start)."""

    host: str = doc("127.0.0.1", "Address to bind: 127.0.0.1 (this machine only) unless opened on purpose.")
    port: int = doc(8080, "TCP port (0: any free port, printed at start).", ge=0, le=65535)
    threads: int = doc(
        0, "Plans run at once, each on one torch thread (0: the machine's cores).", ge=0
    )
    max_request_mb: float = doc(32.0, "Largest request body accepted (MB); larger ones get 413.", gt=0)
    max_pixels: int = doc(
        4096 * 4096, "Largest depth image accepted (width x height), read from its header before decoding.",
        ge=1,
    )
    timeout_s: float = doc(
        30.0, "A plan taking longer is answered 504 (it finishes in the background, its result dropped).",
        gt=0,
    )
    preload: tuple[str, ...] = doc(
        (), "Tasks whose default planner is loaded at start (else on the first request for each)."
    )


# --- reading a request ---------------------------------------------------------------------------------
def image_shape(data: bytes) -> tuple[int, int] | None:
    """(height, width) from a PNG's or a .npy's header, without decoding it (None for other formats or
    an unreadable header: the decoder then says what is wrong)."""
    if data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) >= 24:
        return int.from_bytes(data[20:24], "big"), int.from_bytes(data[16:20], "big")
    if data.startswith(b"\x93NUMPY"):
        import io

        try:
            buf = io.BytesIO(data)
            fmt = np.lib.format
            version = fmt.read_magic(buf)
            read = {(1, 0): fmt.read_array_header_1_0, (2, 0): fmt.read_array_header_2_0}.get(version)
            if read is None:
                return None
            shape = read(buf)[0]
        except (ValueError, OSError, AttributeError):
            return None
        return (int(shape[0]), int(shape[1])) if len(shape) >= 2 else None
    return None


def read_depth(data: bytes, config: ServeConfig) -> np.ndarray:
    """The depth image of a request as stored (float metres or integer millimetres, as ``tognet plan``
    reads files; the planner converts it and judges its unit); RequestError for an empty, oversized or
    unreadable one."""
    from tognet.grasping.depth import depth_suffix, read_depth_bytes

    if not data:
        raise RequestError("depth: the file is empty")
    shape = image_shape(data)
    if shape is not None and shape[0] * shape[1] > config.max_pixels:
        raise RequestError(f"depth: the image is {shape[1]} x {shape[0]} pixels, over the limit of "
                           f"{config.max_pixels} (ServeConfig.max_pixels)", 413)
    suffix = depth_suffix(data)
    if suffix is None:
        raise RequestError("depth: not a 16-bit PNG, .npy or .npz file (unknown first bytes)")
    return read_depth_bytes(data, suffix, "depth")


def _json_field(text: str | None, name: str) -> Any:
    if text is None:
        return None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise RequestError(f"{name}: not valid JSON ({exc})") from None


def _numbers(text: str | None, name: str, count: int) -> tuple[float, ...] | None:
    if text is None or not text.strip():
        return None
    try:
        values = tuple(float(v) for v in text.replace(",", " ").split())
    except ValueError:
        values = ()
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise RequestError(f"{name}: expected {count} finite numbers, got {text!r}")
    return values


def plan_inputs(form: dict[str, Any], config: ServeConfig) -> dict[str, Any]:
    """The planner's inputs from a request's fields (``depth`` as bytes, the rest text); RequestError for
    a missing or unusable one."""
    from tognet.planning.user import parse_object

    missing = [k for k in ("depth", "intrinsics", "task") if form.get(k) in (None, b"", "")]
    if missing:
        raise RequestError(f"missing field(s): {', '.join(missing)} (POST /plan takes depth, intrinsics and "
                           "task; see /docs)", 422)
    try:
        choice = parse_object(form.get("object"))
    except ValueError as exc:
        raise RequestError(str(exc).replace("--object", "object")) from None
    pose = _json_field(form.get("camera_pose"), "camera_pose")
    if isinstance(pose, dict):
        pose = pose.get("world_from_camera", pose.get("pose"))
    return {
        "depth": read_depth(form["depth"], config),
        "intrinsics": _json_field(form["intrinsics"], "intrinsics"),
        "camera_pose": pose,
        "task": str(form["task"]),
        "method": form.get("method") or None,
        "object": choice,
        "reference": _numbers(form.get("reference"), "reference", 3),
        "robot": form.get("robot") or None,
        "base_pose": _json_field(form.get("base_pose"), "base_pose"),
        "top": _int(form.get("top"), "top", 3),
        "seed": _int(form.get("seed"), "seed", 0),
    }


def _int(text: str | None, name: str, default: int) -> int:
    if text is None or text == "":
        return default
    try:
        value = int(text)
    except ValueError:
        raise RequestError(f"{name}: expected a whole number, got {text!r}") from None
    if value < 0:
        raise RequestError(f"{name}: must be 0 or more, got {value}")
    return value


# --- planning --------------------------------------------------------------------------------------------
class Planners:
    """The planners of each worker thread, made on first use and kept: one per (task, method, robot,
    base, top)."""

    def __init__(self) -> None:
        self._local = threading.local()
        self.loaded: set[tuple[Any, ...]] = set()

    def get(self, task: str, method: str | None, robot: str | None, base_pose: Any, top: int) -> Any:
        from tognet.planning.user import UserPlanConfig, UserPlanner

        cache = getattr(self._local, "planners", None)
        if cache is None:
            cache = self._local.planners = {}
        key = (task, method, robot, json.dumps(base_pose, sort_keys=True), top)
        if key not in cache:
            cache[key] = UserPlanner(task, config=UserPlanConfig(top=top), method=method,
                                     robot=_arm(robot, base_pose))
            self.loaded.add(key)
        return cache[key]


def _arm(robot: str | None, base_pose: Any) -> Any:
    """The arm's config for a request (None without one)."""
    if robot is None:
        if base_pose is not None:
            raise RequestError("base_pose places the robot's arm: name the arm with robot=sawyer|panda")
        return None
    from tognet.sim.config import SimConfig, with_robot

    arm = with_robot(SimConfig(), robot)
    if base_pose is not None:
        if not isinstance(base_pose, dict) or set(base_pose) - {"position", "yaw"} or len(
                base_pose.get("position") or []) != 3:
            raise RequestError('base_pose: expected {"position": [x, y, z], "yaw": radians}')
        arm = arm.replace(robot=arm.robot.replace(base_position=tuple(map(float, base_pose["position"])),
                                                  base_yaw=float(base_pose["yaw"])))
    return arm


def run_plan(planners: Planners, inputs: dict[str, Any]) -> dict[str, Any]:
    """One plan (in a worker thread): the JSON of ``tognet plan --out``."""
    import torch

    torch.set_num_threads(1)
    planner = planners.get(inputs["task"], inputs["method"], inputs["robot"], inputs["base_pose"],
                           inputs["top"])
    plan = planner.plan(inputs["depth"], inputs["intrinsics"], inputs["camera_pose"],
                        reference=inputs["reference"], seed=inputs["seed"], object=inputs["object"])
    return plan.to_dict()


def status_of(exc: BaseException) -> int:
    """The HTTP status of an error raised by a plan: 4xx for what is wrong with the request or the
    image, 500 for anything else."""
    from tognet.planning.plan import PlanningError

    if isinstance(exc, RequestError):
        return exc.status
    if isinstance(exc, PlanningError):
        return 422  # nothing to plan on this image (no candidate, none within the arm's reach)
    if isinstance(exc, TognetError | ValueError | FileNotFoundError):
        return 400
    return 500


def one_line(exc: BaseException) -> str:
    """An error as one line."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if status_of(exc) < 500 else f"internal error: {type(exc).__name__}: {text}"


# --- the app ---------------------------------------------------------------------------------------------
def create_app(config: ServeConfig | None = None) -> FastAPI:
    """The FastAPI app of the service (run it with uvicorn, or mount it under Ray Serve)."""
    config = config or ServeConfig()
    threads = config.threads or os.cpu_count() or 1
    pool = ThreadPoolExecutor(threads, thread_name_prefix="plan")
    planners = Planners()
    state = {"started": time.time(), "requests": 0, "errors": 0}
    app = FastAPI(title="tognet planning service", version=_version(), docs_url=None, redoc_url=None,
                  description="Task-oriented grasps and the task's motion on a depth image (see the README).")

    def error(status: int, message: str) -> JSONResponse:
        state["errors"] += 1
        return JSONResponse({"error": message}, status_code=status)

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        parts = [f"{'.'.join(str(x) for x in e.get('loc', ())[1:]) or 'request'}: {e.get('msg')}"
                 for e in exc.errors()]
        return error(422, "; ".join(parts) or "invalid request")

    @app.exception_handler(HTTPException)
    async def _http(request: Request, exc: HTTPException) -> JSONResponse:
        return error(exc.status_code, str(exc.detail))

    @app.exception_handler(Exception)
    async def _any(request: Request, exc: Exception) -> JSONResponse:
        return error(status_of(exc), one_line(exc))

    @app.get("/health", summary="Alive, and what it has loaded")
    async def health() -> dict[str, Any]:
        return {"status": "ok", "version": _version(), "uptime_s": round(time.time() - state["started"], 1),
                "requests": state["requests"], "errors": state["errors"], "threads": threads,
                "planners": sorted(f"{k[0]}/{k[1] or 'default'}" + (f"/{k[2]}" if k[2] else "")
                                   for k in planners.loaded)}

    @app.get("/methods", summary="Tasks, the methods a robot can run, their models and the defaults")
    async def methods() -> dict[str, Any]:
        return describe_methods()

    @app.get("/docs", include_in_schema=False)
    async def docs() -> HTMLResponse:
        return HTMLResponse(docs_page(app.openapi()))

    @app.post("/plan", summary="Plan a grasp and the task's motion on a depth image",
              openapi_extra={"requestBody": {"required": True, "content": {
                  "multipart/form-data": {"schema": PLAN_FORM}}}})
    async def plan(request: Request) -> JSONResponse:
        state["requests"] += 1
        size = int(request.headers.get("content-length") or 0)
        if size > config.max_request_mb * 1e6:
            return error(413, f"the request is {size / 1e6:.1f} MB, over the limit of "
                         f"{config.max_request_mb:g} MB (ServeConfig.max_request_mb)")
        try:
            form = await _form(request)
            inputs = plan_inputs(form, config)
            loop = asyncio.get_running_loop()
            future = loop.run_in_executor(pool, run_plan, planners, inputs)
            body = await asyncio.wait_for(future, config.timeout_s)
        except TimeoutError:
            return error(504, f"the plan took over {config.timeout_s:g} s (ServeConfig.timeout_s)")
        except Exception as exc:  # noqa: BLE001 (every error is one line and the service goes on)
            return error(status_of(exc), one_line(exc))
        return JSONResponse(body)

    if config.preload:
        for task in config.preload:
            planners.loaded.add((task, None, None, "null", 3))
            pool.submit(planners.get, task, None, None, None, 3).result()
    app.state.config, app.state.pool = config, pool
    return app


async def _form(request: Request) -> dict[str, Any]:
    """The multipart form's fields: files as bytes, the rest as text."""
    try:
        form = await request.form()
    except Exception as exc:  # noqa: BLE001 (a body that is not a multipart form)
        raise RequestError(f"the body is not a multipart form ({one_line(exc)}); send depth and intrinsics "
                           "as form fields (curl -F)") from None
    out: dict[str, Any] = {}
    for key, value in form.multi_items():
        if hasattr(value, "read"):
            data = await value.read()
            out[key] = data if key == "depth" else data.decode("utf-8", errors="replace")
        else:
            out[key] = value.encode() if key == "depth" else value
    return out


#: The fields of ``POST /plan`` (multipart/form-data), as the OpenAPI schema states them.
PLAN_FORM: dict[str, Any] = {"type": "object", "required": ["depth", "intrinsics", "task"], "properties": {
    "depth": {"type": "string", "format": "binary",
              "description": "The depth image: a 16-bit PNG in millimetres (0: no reading), or .npy/.npz "
                             "(float metres, or integer millimetres)."},
    "intrinsics": {"type": "string", "description": 'JSON {"width", "height", "fx", "fy", "cx", "cy"} '
                                                     "in pixels (the README's intrinsics file)."},
    "task": {"type": "string", "description": "sweeping, hammering or pulling."},
    "method": {"type": "string", "description": "A method a robot can run (GET /methods); default the "
                                                 "best with shipped models."},
    "camera_pose": {"type": "string", "description": 'JSON {"world_from_camera": 4 x 4} (world z = 0 the '
                                                      "table top); without it the table plane is fitted."},
    "object": {"type": "string", "description": "The object to plan on: an index, or a pixel 'u,v'."},
    "reference": {"type": "string", "description": "The task's reference point 'x,y,z' (m)."},
    "robot": {"type": "string", "description": "sawyer or panda: plan only what that arm reaches."},
    "base_pose": {"type": "string", "description": 'JSON {"position": [x, y, z], "yaw": rad} of the arm.'},
    "top": {"type": "integer", "description": "Alternatives beside the chosen grasp (default 3)."},
    "seed": {"type": "integer", "description": "Seed of the sampler and the search (default 0)."},
}}


def docs_page(schema: dict[str, Any]) -> str:
    """The OpenAPI schema as a self-contained HTML page (no scripts, nothing fetched: it renders offline)."""
    from html import escape

    rows = []
    for path, ops in schema.get("paths", {}).items():
        for verb, op in ops.items():
            summary = escape(op.get("summary", ""))
            rows.append(f"<h2><code>{verb.upper()} {escape(path)}</code></h2><p>{summary}</p>")
            form = (op.get("requestBody", {}).get("content", {}).get("multipart/form-data", {})
                    .get("schema", {}))
            if form:
                need = set(form.get("required", []))
                items = "".join(f"<tr><td><code>{escape(k)}</code>{' (required)' if k in need else ''}</td>"
                                f"<td>{escape(v.get('description', ''))}</td></tr>"
                                for k, v in form.get("properties", {}).items())
                rows.append(f"<table>{items}</table>")
    info = schema.get("info", {})
    return ("<!doctype html><html><head><meta charset='utf-8'><title>" + escape(info.get("title", "")) +
            "</title><style>body{font-family:sans-serif;margin:2em;max-width:60em}td{padding:.3em .8em;"
            "border-bottom:1px solid #ddd;vertical-align:top}h2{font-size:1.1em;margin-top:1.5em}</style>"
            f"</head><body><h1>{escape(info.get('title', ''))} {escape(info.get('version', ''))}</h1>"
            f"<p>{escape(info.get('description', ''))}</p><p>The schema: "
            "<a href='/openapi.json'>/openapi.json</a>. Errors are one line of JSON, "
            "<code>{&quot;error&quot;: &quot;...&quot;}</code>.</p>" + "".join(rows)
            + "<h2>Example</h2><pre>curl -F depth=@d.png -F intrinsics=@d.intrinsics.json -F task=hammering "
            "http://127.0.0.1:8080/plan</pre></body></html>")


def describe_methods() -> dict[str, Any]:
    """What ``GET /methods`` answers: per task the default method and, per method a robot can run, its
    models and whether they ship."""
    from tognet.models import MODELS_DIR
    from tognet.planning.methods import BEST_FIRST, METHOD_TABLE, NEEDS, default_method
    from tognet.tasks import GRASP_ONLY, TASK_NAMES

    def shipped(kind: str, task: str) -> str:
        return {"grasp": GRASP_ONLY, "task": task, "search": f"{task}_search"}[kind]

    tasks = {}
    for task in TASK_NAMES:
        def there(needs: tuple[str, ...], task: str = task) -> bool:
            return all((MODELS_DIR / f"{shipped(n, task)}.pt").is_file() for n in needs)

        rows = {m: {"models": {n: f"tognet/models/{shipped(n, task)}.pt" for n in NEEDS[m]},
                    "shipped": there(NEEDS[m])} for m in BEST_FIRST}
        tasks[task] = {"default": default_method(there), "methods": rows}
    scores = {m.name: m.score for m in METHOD_TABLE if m.name in BEST_FIRST}
    return {"tasks": tasks, "scores": scores,
            "refused": [m.name for m in METHOD_TABLE if m.uses_sim]}


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("tognet")
    except PackageNotFoundError:
        return "unknown"
