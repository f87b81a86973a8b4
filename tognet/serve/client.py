"""A small client of the planning service (``tognet serve``), standard library only.

    from tognet.serve import Client
    plan = Client("http://127.0.0.1:8080").plan("depth.png", "intrinsics.json", task="hammering")
    plan["grasp"]["table"], plan["method"]                  # the JSON of ``tognet plan --out``
"""

from __future__ import annotations

import io
import json
import uuid
from pathlib import Path
from typing import Any
from urllib import error, request

import numpy as np

from tognet.errors import TognetError


class ServiceError(TognetError):
    """The service answered with an error: ``status`` and its one-line ``message``."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(f"{status}: {message}")
        self.status = status
        self.message = message


def _depth_bytes(depth: Any) -> bytes:
    """A depth image as the service reads it: a file's bytes as they are, an array as .npy bytes."""
    if isinstance(depth, str | Path):
        return Path(depth).read_bytes()
    if isinstance(depth, bytes):
        return depth
    buf = io.BytesIO()
    np.save(buf, np.asarray(depth), allow_pickle=False)
    return buf.getvalue()


def _json_text(value: Any) -> str | None:
    """A JSON field: a file's text, a dict or list as JSON (arrays as lists), None left out."""
    if value is None:
        return None
    if isinstance(value, str | Path) and Path(value).is_file():
        return Path(value).read_text()
    if hasattr(value, "width") and hasattr(value, "fx"):  # CameraIntrinsics
        value = {k: getattr(value, k) for k in ("width", "height", "fx", "fy", "cx", "cy")}
    return json.dumps(np.asarray(value).tolist() if isinstance(value, np.ndarray) else value)


def multipart(fields: dict[str, str], files: dict[str, bytes]) -> tuple[bytes, str]:
    """A multipart/form-data body and its content type."""
    boundary = uuid.uuid4().hex
    parts: list[bytes] = []
    for name, text in fields.items():
        head = f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"\r\n\r\n'
        parts.append(f"{head}{text}\r\n".encode())
    for name, data in files.items():
        parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"; filename="{name}"\r\n'
                     "Content-Type: application/octet-stream\r\n\r\n".encode() + data + b"\r\n")
    parts.append(f"--{boundary}--\r\n".encode())
    return b"".join(parts), f"multipart/form-data; boundary={boundary}"


class Client:
    """The service at ``url`` (e.g. ``http://127.0.0.1:8080``); ``timeout``: seconds per request."""

    def __init__(self, url: str, timeout: float = 60.0) -> None:
        self.url = url.rstrip("/")
        self.timeout = timeout

    def _call(self, path: str, body: bytes | None = None, content_type: str | None = None) -> dict[str, Any]:
        req = request.Request(self.url + path, data=body, method="POST" if body is not None else "GET")
        if content_type:
            req.add_header("Content-Type", content_type)
        try:
            with request.urlopen(req, timeout=self.timeout) as answer:  # noqa: S310 (the user's own URL)
                return dict(json.loads(answer.read()))
        except error.HTTPError as exc:
            text = exc.read().decode("utf-8", errors="replace")
            try:
                message = json.loads(text).get("error", text)
            except (json.JSONDecodeError, AttributeError):
                message = text.strip() or exc.reason
            raise ServiceError(exc.code, str(message)) from None

    def health(self) -> dict[str, Any]:
        """``GET /health``."""
        return self._call("/health")

    def methods(self) -> dict[str, Any]:
        """``GET /methods``."""
        return self._call("/methods")

    def plan(self, depth: Any, intrinsics: Any, task: str, *, method: str | None = None,
             camera_pose: Any = None, object: int | tuple[float, float] | None = None,
             reference: tuple[float, float, float] | None = None, robot: str | None = None,
             base_pose: dict[str, Any] | None = None, top: int | None = None, seed: int | None = None
             ) -> dict[str, Any]:
        """A plan (the JSON of ``tognet plan --out`` as a dict). ``depth``: an array (float metres or
        integer millimetres), a file path or the file's bytes; ``intrinsics``, ``camera_pose``: a JSON file
        path or the value itself. ServiceError with the service's one line for a refused request."""
        fields = {"task": task, "intrinsics": _json_text(intrinsics), "camera_pose": _json_text(camera_pose),
                  "method": method, "robot": robot, "base_pose": _json_text(base_pose),
                  "object": None if object is None else (str(object) if isinstance(object, int)
                                                         else f"{object[0]},{object[1]}"),
                  "reference": None if reference is None else ",".join(map(str, reference)),
                  "top": None if top is None else str(top), "seed": None if seed is None else str(seed)}
        body, kind = multipart({k: v for k, v in fields.items() if v is not None},
                               {"depth": _depth_bytes(depth)})
        return self._call("/plan", body, kind)
