"""The planning service (issue 32): a real `tognet serve` on 127.0.0.1, started here and ended by its PID;
plans equal to the in-process API's, and every bad request answered with one line while it keeps serving."""

import io
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("fastapi", reason="the serve extra (pip install 'tognet[serve]')")

from tognet.planning.camera import intrinsics_dict, save_depth_png, save_intrinsics  # noqa: E402
from tognet.serve.client import Client, ServiceError, multipart  # noqa: E402

TASK = "hammering"


@pytest.fixture(scope="module")
def scene(hammer_sim, tmp_path_factory):
    obs = hammer_sim.reset(3)
    root = tmp_path_factory.mktemp("serve")
    return {"obs": obs, "png": save_depth_png(root / "d.png", obs.depth),
            "intrinsics": save_intrinsics(root / "k.json", obs.camera.intrinsics), "root": root}


@pytest.fixture(scope="module")
def service():
    """`tognet serve --port 0` in its own process; (URL, the process)."""
    exe = Path(sys.executable).with_name("tognet")
    proc = subprocess.Popen([str(exe), "serve", "--port", "0", "--threads", "2", "--preload", TASK,
                             "--timeout", "20"], stderr=subprocess.PIPE, text=True)
    url = None
    deadline = time.time() + 120
    while time.time() < deadline and url is None:
        line = proc.stderr.readline()
        found = re.search(r"listening on (http://127\.0\.0\.1:\d+)", line)
        url = found.group(1) if found else None
        if not line and proc.poll() is not None:
            break
    if url is None:
        proc.kill()
        pytest.fail("tognet serve did not start")
    yield url, proc
    os.kill(proc.pid, signal.SIGTERM)
    proc.wait(timeout=30)


def _post(url, fields, files):
    body, kind = multipart(fields, files)
    import urllib.error
    import urllib.request

    req = urllib.request.Request(url + "/plan", data=body, method="POST", headers={"Content-Type": kind})
    try:
        with urllib.request.urlopen(req, timeout=60) as answer:
            return answer.status, answer.read().decode()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read().decode()


def test_a_plan_from_the_service_is_the_in_process_plan(service, scene):
    import tognet

    url, _ = service
    client = Client(url)
    obs = scene["obs"]
    remote = client.plan(scene["png"], scene["intrinsics"], task=TASK)
    local = tognet.plan(scene["png"], scene["intrinsics"], task=TASK)
    assert remote["method"] == local.method == "TOG-Net+ActionSearch"
    mine = json.loads(json.dumps(local.to_dict()))
    assert remote["grasp"] == mine["grasp"] and remote["alternatives"] == mine["alternatives"]
    assert remote["object"] == mine["object"] and remote["warnings"] == mine["warnings"]
    # an array (float metres) with the intrinsics as a dict and a camera pose, another method
    arr = client.plan(obs.depth, intrinsics_dict(obs.camera.intrinsics), task=TASK, method="TOG-Net",
                      camera_pose=obs.camera.pose, top=1)
    assert arr["method"] == "TOG-Net" and len(arr["alternatives"]) == 1 and arr["grasp"]["world"] is not None
    health = client.health()
    assert health["status"] == "ok" and health["requests"] >= 2
    methods = client.methods()
    assert methods["tasks"][TASK]["default"] == "TOG-Net+ActionSearch" and "Oracle" in methods["refused"]


def _bad_requests(scene):
    """(name, form fields, files, the status expected, a piece of the one-line error)."""
    k = scene["intrinsics"].read_text()
    png = scene["png"].read_bytes()
    bools = io.BytesIO()
    np.save(bools, np.ones((424, 512), bool))
    flat = io.BytesIO()
    np.save(flat, np.full((424, 512), 0.72, np.float32))  # the table alone: nothing to pick up
    huge = io.BytesIO()
    from PIL import Image

    Image.fromarray(np.zeros((8000, 8000), np.uint16)).save(huge, format="PNG")
    task = {"task": TASK, "intrinsics": k}
    return [
        ("malformed JSON", {"task": TASK, "intrinsics": "{'width': 512"}, {"depth": png}, 400,
         "not valid json"),
        ("truncated PNG", task, {"depth": png[: len(png) // 3]}, 400, "truncated"),
        ("wrong dtype", task, {"depth": bools.getvalue()}, 400, "numeric"),
        ("8000 x 8000", task, {"depth": huge.getvalue()}, 413, "8000 x 8000"),
        ("missing field", {"task": TASK}, {"depth": png}, 422, "missing field(s): intrinsics"),
        ("unknown method", {**task, "method": "Magic"}, {"depth": png}, 400, "unknown method 'magic'"),
        ("the Oracle", {**task, "method": "Oracle"}, {"depth": png}, 400, "needs the simulator"),
        ("unknown task", {**task, "task": "juggling"}, {"depth": png}, 400, "unknown task 'juggling'"),
        ("not an image", task, {"depth": b"hello"}, 400, "not a 16-bit png"),
        ("the planner raises", task, {"depth": flat.getvalue()}, 400, "no object on the table"),
        ("bad object", {**task, "object": "left"}, {"depth": png}, 400, "object takes an object's index"),
    ]


def test_every_bad_request_gets_one_line_and_the_service_goes_on(service, scene):
    url, proc = service
    for name, fields, files, status, expect in _bad_requests(scene):
        code, text = _post(url, fields, files)
        body = json.loads(text)
        assert code == status, (name, code, text)
        assert set(body) == {"error"} and "\n" not in body["error"], (name, body)
        assert expect in body["error"].lower(), (name, body)
        assert Client(url).health()["status"] == "ok", name  # still up
    assert proc.poll() is None
    assert Client(url).plan(scene["png"], scene["intrinsics"], task=TASK, top=0)["grasp"]
    with pytest.raises(ServiceError, match="400: unknown method"):
        Client(url).plan(scene["png"], scene["intrinsics"], task=TASK, method="Magic")


def test_a_slow_client_holds_up_nobody(service, scene):
    """A client that sends half a request and stalls: the others are served meanwhile."""
    url, _ = service
    host, port = url.removeprefix("http://").split(":")
    body, kind = multipart({"task": TASK, "intrinsics": scene["intrinsics"].read_text()},
                           {"depth": scene["png"].read_bytes()})
    slow = socket.create_connection((host, int(port)), timeout=30)
    try:
        slow.sendall(f"POST /plan HTTP/1.1\r\nHost: {host}\r\nContent-Type: {kind}\r\n"
                     f"Content-Length: {len(body)}\r\n\r\n".encode() + body[: len(body) // 2])
        t0 = time.perf_counter()
        assert Client(url).plan(scene["png"], scene["intrinsics"], task=TASK, top=0)["grasp"]
        assert time.perf_counter() - t0 < 10
        slow.sendall(body[len(body) // 2:])  # and it is answered once it has sent everything
        reply = _read_reply(slow)
        assert reply.startswith("HTTP/1.1 200"), reply[:200]
    finally:
        slow.close()


def _read_reply(sock):
    """A whole HTTP reply (head and a body of its Content-Length), however many packets it comes in."""
    data = b""
    while b"\r\n\r\n" not in data or len(data.partition(b"\r\n\r\n")[2]) < _length(data):
        chunk = sock.recv(4096)
        if not chunk:
            break
        data += chunk
    return data.decode(errors="replace")


def _length(data):
    found = re.search(rb"content-length: *(\d+)", data.partition(b"\r\n\r\n")[0], re.IGNORECASE)
    return int(found.group(1)) if found else 0


def test_an_oversized_request_is_refused_by_its_length(service):
    """A request announcing 40 MB is answered 413 from its headers, before its body is read."""
    url, proc = service
    host, port = url.removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=30) as sock:
        sock.sendall(f"POST /plan HTTP/1.1\r\nHost: {host}\r\n".encode()
                     + b"Content-Type: multipart/form-data; boundary=x\r\nContent-Length: 40000000\r\n\r\n")
        reply = _read_reply(sock)
    head, _, body = reply.partition("\r\n\r\n")
    assert head.startswith("HTTP/1.1 413"), reply
    assert "over the limit of 32 mb" in json.loads(body)["error"].lower()
    assert Client(url).health()["status"] == "ok" and proc.poll() is None


def test_the_docs_page_renders_in_a_headless_browser(service, tmp_path):
    url, _ = service
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser is None:
        pytest.skip("no Chromium here (CI installs Debian's chromium: make system-deps)")
    shot = tmp_path / "docs.png"
    subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                    "--no-first-run", "--disable-background-networking", "--disable-component-update",
                    "--disable-sync",
                    f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1200,900",
                    "--virtual-time-budget=5000", f"--screenshot={shot}", f"{url}/docs"],
                   check=True, capture_output=True, timeout=120)
    from PIL import Image

    img = np.asarray(Image.open(shot).convert("L"), dtype=np.float64)
    assert img.shape == (900, 1200) and img.std() > 5  # a page, not a blank
