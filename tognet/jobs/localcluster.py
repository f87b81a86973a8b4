"""A real Ray cluster on this machine whose worker nodes cannot see chosen folders (tests, benchmarks).

Ray advertises and binds a node's routable address even when told 127.0.0.1, so the cluster lives in a
network namespace of its own with only the loopback interface up: nothing in it can be reached from
outside the machine. The head node runs no tasks (``--num-cpus=0``); each worker node also has a mount
namespace of its own (``unshare -m``, as root) with an empty tmpfs over every hidden folder, so what it
reads of the run folder, the objects or the checkpoints can only have come through Ray. A driver (the
``tognet`` command under test) joins the namespace through :meth:`LocalCluster.command`. Token
authentication is off for this private cluster (``RAY_AUTH_MODE=disabled``; a real cluster keeps it
on). :meth:`LocalCluster.close` ends only the processes it started, by session.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType

#: Run in ``unshare -n``: bring the loopback interface up (SIOCGIFFLAGS / SIOCSIFFLAGS), then hold the
#: namespace open until killed.
_HOLDER = (
    "import fcntl, signal, socket, struct\n"
    "s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)\n"
    "flags = struct.unpack('16sh', fcntl.ioctl(s, 0x8913, struct.pack('16sh', b'lo', 0)))[1]\n"
    "fcntl.ioctl(s, 0x8914, struct.pack('16sh', b'lo', flags | 1))\n"
    "print('up', flush=True)\n"
    "signal.pause()\n"
)


def unavailable() -> str | None:
    """Why a blind-node cluster cannot be started here, or None when it can."""
    if os.geteuid() != 0:
        return "needs root (worker nodes hide folders with unshare -m and a tmpfs mount)"
    for tool in ("unshare", "nsenter"):
        if shutil.which(tool) is None:
            return f"needs util-linux's {tool}"
    try:
        import ray  # noqa: F401
    except ImportError:
        return "needs Ray (pip install 'tognet[ray]')"
    probe = subprocess.run(["unshare", "-m", "-n", "--propagation", "private", "true"], capture_output=True)
    if probe.returncode != 0:
        return f"unshare -m -n is refused here ({probe.stderr.decode().strip() or probe.returncode})"
    return None


def _session_pids(sid: int) -> list[int]:
    """Processes of session ``sid`` (a node started with its own session)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if os.getsid(int(entry.name)) == sid:
                    pids.append(int(entry.name))
            except OSError:
                continue
    return pids


def _comm(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/comm").read_text().strip()
    except OSError:
        return ""


class LocalCluster:
    """A head and any number of blind worker nodes in a private network namespace, on port 6379 of its
    loopback interface (:attr:`address`)."""

    def __init__(self, hide: Sequence[str | Path], env: dict[str, str] | None = None) -> None:
        reason = unavailable()
        if reason:
            raise RuntimeError(f"cannot start a local Ray cluster: {reason}")
        self.hide = [Path(p).resolve() for p in hide]
        self.address = "127.0.0.1:6379"
        self.temp = Path(tempfile.mkdtemp(prefix="tgr", dir="/tmp"))  # short: Ray's socket paths
        self.env = {**os.environ, "RAY_AUTH_MODE": "disabled", "RAY_USAGE_STATS_ENABLED": "0", **(env or {})}
        self.nodes: list[subprocess.Popen[bytes]] = []
        self._ray = str(Path(sys.executable).parent / "ray")
        self._procs: list[subprocess.Popen[bytes]] = []
        self._holder: subprocess.Popen[bytes] | None = None

    def command(self, args: Sequence[str]) -> list[str]:
        """``args`` run inside the cluster's network namespace (a driver: ``tognet ... --ray-address``)."""
        if self._holder is None:
            raise RuntimeError("the cluster is not started")
        return ["nsenter", f"--net=/proc/{self._holder.pid}/ns/net", *args]

    def _start(self, args: list[str], log: str, env: dict[str, str] | None = None) -> subprocess.Popen[bytes]:
        with open(self.temp / log, "ab") as out:
            proc = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, env=env or self.env,
                                    start_new_session=True)
        self._procs.append(proc)
        return proc

    def _wait_for(self, proc: subprocess.Popen[bytes], log: str, line: str, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while line not in (self.temp / log).read_text(errors="replace"):
            if time.monotonic() > deadline or proc.poll() is not None:
                raise RuntimeError(f"Ray did not start: see {self.temp / log}")
            time.sleep(0.2)

    def start(self, timeout: float = 60.0) -> LocalCluster:
        """The network namespace, then the head (no CPUs for tasks)."""
        self._holder = self._start(["unshare", "-n", sys.executable, "-c", _HOLDER], "net.log")
        self._wait_for(self._holder, "net.log", "up", timeout)
        head = self._start(self.command([self._ray, "start", "--head", "--node-ip-address=127.0.0.1",
                                         "--port=6379", "--num-cpus=0", "--include-dashboard=false",
                                         "--disable-usage-stats", f"--temp-dir={self.temp}", "--block"]),
                           "head.log")
        self._wait_for(head, "head.log", "Ray runtime started", timeout)
        return self

    def add_node(self, cpus: int, cache: str | Path, timeout: float = 60.0) -> subprocess.Popen[bytes]:
        """A worker node with ``cpus`` CPUs and its file cache at ``cache`` that sees none of the hidden
        folders; returns once it has joined."""
        mounts = "".join(f"mount -t tmpfs tmpfs '{p}' && " for p in self.hide)
        script = (f"{mounts}exec '{self._ray}' start --address={self.address} --node-ip-address=127.0.0.1 "
                  f"--num-cpus={cpus} --disable-usage-stats --block")
        log = f"node{len(self.nodes)}.log"
        node = self._start(self.command(["unshare", "-m", "--propagation", "private", "sh", "-c", script]),
                           log, env={**self.env, "TOGNET_CACHE_DIR": str(cache)})
        self.nodes.append(node)
        self._wait_for(node, log, "Ray runtime started", timeout)
        return node

    def raylet_pid(self, node: subprocess.Popen[bytes]) -> int:
        """The raylet of one of this cluster's worker nodes."""
        for pid in _session_pids(node.pid):
            if _comm(pid) == "raylet":
                return pid
        raise RuntimeError("the node has no raylet running")

    def kill_node(self, node: subprocess.Popen[bytes]) -> int:
        """SIGKILL the node's raylet (a machine lost, as the cluster sees it); returns its PID."""
        pid = self.raylet_pid(node)
        os.kill(pid, signal.SIGKILL)
        return pid

    def close(self) -> None:
        """End every process this cluster started (each in a session of its own), newest first."""
        for proc in reversed(self._procs):
            for pid in _session_pids(proc.pid):
                try:
                    os.kill(pid, signal.SIGKILL)
                except OSError:
                    pass
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                pass
        self._procs.clear()
        shutil.rmtree(self.temp, ignore_errors=True)

    def __enter__(self) -> LocalCluster:
        return self.start()

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


__all__ = ["LocalCluster", "unavailable"]
