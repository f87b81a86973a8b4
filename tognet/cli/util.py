"""Helpers shared by the subcommands: turn expected errors into one clear line and exit status 2.

The one place where a command's user-fixable errors become one line: :func:`user_errors` wraps every
command. It prints ``error: <message>`` for the library's own errors (:class:`TognetError`,
:class:`ConfigError`, ``ValueError``) and turns any operating-system error on a file (missing, permission,
a file where a folder is wanted, a full disk, ...) into one line that names the command's option or
argument holding the path and what to do (:func:`os_error_message`). Output paths are checked before any
long work by :func:`out_file` and :func:`out_folder`, and counts that cannot fit by :func:`check_disk`.
"""

from __future__ import annotations

import errno
import functools
import inspect
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar

import typer

from tognet.cli.interrupt import Stopped
from tognet.config import ConfigError
from tognet.errors import TognetError
from tognet.io import FolderLock
from tognet.robot.names import ARM_BASES, FLOATING, check_robot_name

F = TypeVar("F", bound=Callable[..., Any])

#: Exceptions whose message is written for the user; anything else is a bug and keeps its traceback.
USER_ERRORS: tuple[type[BaseException], ...] = (TognetError, ConfigError, OSError, ValueError)


#: ``--workers``, ``--ray`` and ``--ray-address`` of the commands that run jobs (collection, evaluation).
WORKERS_HELP = "Local worker processes (default: the number of cores)."
RAY_HELP = "Run the jobs on a local Ray instance (pip install 'tognet\\[ray]')."
RAY_ADDRESS_HELP = "Run the jobs on this Ray cluster ('auto', or 'ray://HOST:10001')."

#: ``--task`` of the commands that run several tasks: a task's name, ``all`` (every registered task) or
#: ``both`` (the paper's two, sweeping and hammering, as before a third task was registered).
TASKS_HELP = (
    "A task's name (or several, comma-separated), 'all' (every registered task), or 'both' (the paper's two)."
)


def either(names: Iterable[str]) -> str:
    """``'a, b or c'`` of ``names`` (at least one), for help texts."""
    *rest, last = names
    return f"{', '.join(rest)} or {last}" if rest else last


ROBOT_HELP = (
    f"What carries the hand: {FLOATING} (the default), {either(ARM_BASES)} (a real arm beside the table, "
    "pip install 'tognet\\[robot]'); an arm's preset (tognet/robot/presets) goes on top of the config."
)


def robot_config(sim: Any, robot: str | None, option: str = "--robot") -> Any:
    """The SimConfig ``sim`` with the hand carried by ``robot`` (None: unchanged); one line when the name
    is unknown or the robot extra is missing (checked before any long work)."""
    if robot is None:
        return sim
    from tognet.sim.config import with_robot

    if check_robot_name(robot, option) != FLOATING:
        from tognet.robot.ik import require_extra

        require_extra()
    return with_robot(sim, robot)


def task_list(spec: str) -> list[str]:
    """The tasks ``--task`` names (see :data:`TASKS_HELP`); an unknown name raises ValueError."""
    from tognet.tasks import PAPER_TASKS, TASK_NAMES, check_task_name

    if spec == "all":
        return list(TASK_NAMES)
    if spec == "both":
        return list(PAPER_TASKS)
    names = [n.strip() for n in spec.split(",") if n.strip()]
    # One name alone may also have been all or both (the message lists them); in a list, only tasks.
    return [check_task_name(n, (*TASK_NAMES, "all", "both") if n == spec else TASK_NAMES) for n in names]


def task_models(pairs: list[str], tasks: Iterable[str] | None = None) -> dict[str, Path]:
    """``--task-model NAME=PATH`` options as {name: checkpoint}: NAME a task (its TOG-Net) or
    ``<task>_search`` (its action-conditioned model, for TOG-Net+ActionSearch). A name given twice, or
    (with ``tasks``) one for a task the command does not run, is refused rather than silently unused."""
    out: dict[str, Path] = {}
    for pair in pairs:
        name, sep, path = pair.partition("=")
        if not sep or not name or not path:
            raise ValueError(f"--task-model takes NAME=PATH, got '{pair}'")
        suffix = "_search" if name.endswith("_search") else ""
        task = task_list(name.removesuffix(suffix))[0]
        key = task + suffix
        if key in out:
            raise ValueError(f"--task-model {key} is given twice ({out[key]} and {path}); give it once")
        if tasks is not None and task not in set(tasks):
            raise ValueError(f"--task-model {pair}: this run evaluates {', '.join(tasks)}, not {task}; the "
                             "model would not be used")
        out[key] = Path(path)
    return out


def _param_names(func: Callable[..., Any]) -> dict[str, str]:
    """{parameter: how the user spells it} for a typer command: ``--out`` for an option, ``OUT`` for an
    argument."""
    names: dict[str, str] = {}
    for name, param in inspect.signature(func).parameters.items():
        info = param.default
        if isinstance(info, typer.models.OptionInfo):
            decls = [d for d in (info.param_decls or ()) if d.startswith("--")]
            names[name] = decls[0].split("/")[0] if decls else "--" + name.replace("_", "-")
        elif isinstance(info, typer.models.ArgumentInfo):
            names[name] = info.metavar or name.upper()
    return names


def _paths(value: Any) -> list[Path]:
    if isinstance(value, Path):
        return [value]
    if isinstance(value, list | tuple):
        return [v for v in value if isinstance(v, Path)]
    return []


def _option_of(filename: str, kwargs: dict[str, Any], names: dict[str, str]) -> tuple[str, Path] | None:
    """The option (and its value) whose path ``filename`` is, lies under, or lies above."""
    target = Path(os.path.abspath(filename))
    best: tuple[int, str, Path] | None = None
    for key, value in kwargs.items():
        for path in _paths(value):
            given = Path(os.path.abspath(path))
            if target == given or given in target.parents or target in given.parents:
                score = len(given.parts)
                if best is None or score > best[0]:
                    best = (score, names.get(key, "--" + key.replace("_", "-")), path)
    return None if best is None else (best[1], best[2])


def _file_above(path: Path) -> Path | None:
    return next((p for p in path.parents if p.exists() and not p.is_dir()), None)


def os_error_reason(exc: OSError, path: Path) -> str:
    """What an operating-system error on ``path`` means for the user, and what to do, in a few words."""
    code = exc.errno
    if code == errno.EEXIST and path.exists() and not path.is_dir():
        code = errno.ENOTDIR  # a folder was to be made where a file is: mkdir's parents=True says EEXIST
        if _file_above(path / "x") is not None:
            return f"{path} is a file, not a folder"
    if code == errno.ENOTDIR:
        above = _file_above(path)
        if above is not None:
            return f"{above} is a file, not a folder"
        return "a part of the path is not a folder"
    if code == errno.ENOENT:
        return "no such file or folder"
    if code in (errno.EACCES, errno.EPERM):
        return "permission denied; choose a path you may read or write"
    if code == errno.EEXIST:
        return "already exists (and is in the way); remove it or choose another path"
    if code == errno.EISDIR:
        return "is a folder; give a file name"
    if code in (errno.ENOSPC, errno.EDQUOT):
        return "no space left on its disk; free some or choose another disk"
    if code == errno.EROFS:
        return "on a read-only file system; choose a writable folder"
    if code == errno.ENAMETOOLONG:
        return "the name is too long"
    return (exc.strerror or type(exc).__name__).lower()


def os_error_message(exc: OSError, where: tuple[str, Path] | None = None) -> str:
    """One line for an operating-system error: the option and its value (when known), the file, the
    reason in the user's terms."""
    if exc.filename is None:
        return str(exc)
    path = Path(os.fsdecode(exc.filename))
    reason = os_error_reason(exc, path)
    if where is None:
        return f"{path}: {reason}"
    option, value = where
    at = "" if Path(os.path.abspath(value)) == Path(os.path.abspath(path)) else f" ({path})"
    return f"{option} {value}: {reason}{at}"


def user_errors(func: F) -> F:
    """Decorator for a command: print ``error: <message>`` (one line) and exit 2 on a user-facing error.

    An operating-system error names the command's option whose path it concerns (see
    :func:`os_error_message`)."""
    names = _param_names(func)

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except USER_ERRORS as exc:
            _report(exc, kwargs, names)
        except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM: tognet.cli.main says what was kept
            raise Stopped(exc) from None
        finally:
            release_folders()

    return wrapper  # type: ignore[return-value]


def _report(exc: BaseException, kwargs: dict[str, Any], names: dict[str, str]) -> None:
    """Print a user-facing error as one line and exit 2 (a closed stdout pipe is raised on, for
    :func:`tognet.cli.main` to end quietly)."""
    if isinstance(exc, OSError) and exc.errno == errno.EPIPE:
        raise exc  # the reader of stdout went away (`tognet ... | head`)
    if isinstance(exc, OSError) and exc.errno is not None:
        where = None if exc.filename is None else _option_of(os.fsdecode(exc.filename), kwargs, names)
        message = os_error_message(exc, where)
    else:
        message = str(exc)
    message = " ".join(message.split()) or type(exc).__name__
    typer.secho(f"error: {message}", err=True, fg=typer.colors.RED)
    raise typer.Exit(code=2) from None


#: Folders the running command holds (:func:`out_folder`), released when it ends.
_HELD: list[FolderLock] = []


def release_folders() -> None:
    """Release every folder the command took (its lock file goes; a folder it made and left empty too)."""
    while _HELD:
        _HELD.pop().release()


def _existing_ancestor(path: Path) -> Path:
    here = Path(os.path.abspath(path))
    while not here.exists():
        here = here.parent
    return here


def _probe_folder(base: Path, option: str, path: Path) -> None:
    """Create and remove an empty folder in ``base``: what the OS says before any long work starts."""
    try:
        probe = tempfile.mkdtemp(prefix=".tognet-probe-", dir=base)
    except OSError as exc:
        raise TognetError(f"{option} {path}: cannot write in {base}: {os_error_reason(exc, base)}") from None
    os.rmdir(probe)


def out_folder(path: Path, option: str = "--out", lock: bool = True) -> Path:
    """``path`` checked as a folder to write into, before any work: a file there (or above it), or a place
    the user may not write, is a one-line user error. With ``lock`` the command then holds the folder
    (:class:`tognet.io.FolderLock`) until it ends: a second run into it is refused with one line naming
    the first; a folder made for it and left empty is removed again."""
    if path.exists() and not path.is_dir():
        raise TognetError(f"{option} {path}: exists and is not a folder (it is a file); pass a folder")
    above = _file_above(path)
    if above is not None:
        raise TognetError(f"{option} {path}: {above} is a file, not a folder")
    _probe_folder(_existing_ancestor(path), option, path)
    if lock:
        _HELD.append(FolderLock(path, option))
    return path


def out_file(path: Path, option: str = "--out", suffix: str | Iterable[str] | None = None) -> Path:
    """``path`` checked as a file to write, before any work: a folder there, a file above it, a wrong
    suffix (when ``suffix`` is given) or a place the user may not write is a one-line user error."""
    if path.is_dir():
        example = path / ("metrics.json" if suffix is None else f"out{_first(suffix)}")
        raise TognetError(f"{option} {path}: is a folder; pass a file name (e.g. {example})")
    if suffix is not None:
        allowed = (suffix,) if isinstance(suffix, str) else tuple(suffix)
        if path.suffix.lower() not in allowed:
            raise TognetError(f"{option} must name a {' or '.join(allowed)} file, got '{path}'")
    above = _file_above(path)
    if above is not None:
        raise TognetError(f"{option} {path}: {above} is a file, not a folder")
    if path.exists():
        try:
            with open(path, "ab"):
                pass
        except OSError as exc:
            raise TognetError(f"{option} {path}: cannot write it: {os_error_reason(exc, path)}") from None
    else:
        _probe_folder(_existing_ancestor(path.parent), option, path)
    return path


def _first(suffix: str | Iterable[str]) -> str:
    return suffix if isinstance(suffix, str) else next(iter(suffix))


def in_file(path: Path, option: str, what: str = "file") -> Path:
    """``path`` checked as an existing, readable file: missing, a folder or unreadable is one line."""
    if path.is_dir():
        raise TognetError(f"{option} {path}: is a folder; give the {what} itself")
    if not path.exists():
        raise TognetError(f"{option} {path}: {what} not found")
    if not os.access(path, os.R_OK):
        raise TognetError(f"{option} {path}: permission denied; it cannot be read")
    return path


def in_folder(path: Path, option: str, what: str = "folder") -> Path:
    """``path`` checked as an existing folder: missing or a file is one line."""
    if not path.exists():
        raise TognetError(f"{option} {path}: {what} not found")
    if not path.is_dir():
        raise TognetError(f"{option} {path}: is a file; give the {what}")
    return path


def positive(value: float, option: str, what: str = "") -> float:
    """``value`` checked to be a positive finite number: a one-line user error naming ``option``."""
    if not (value > 0 and value < float("inf")):
        detail = f" ({what})" if what else ""
        raise TognetError(f"{option} must be a positive number{detail}, got {value}")
    return value


def human_bytes(n: float) -> str:
    """``n`` bytes as a short figure (kB, MB, GB, TB; powers of 1000)."""
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} PB"  # pragma: no cover


def available_memory() -> int:
    """Bytes of memory available to a new allocation (Linux's MemAvailable; else the free pages)."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 1 << 62


def check_memory(option: str, count: int, bytes_each: float, what: str, label: str | None = None) -> None:
    """Refuse ``count`` items held in memory at about ``bytes_each`` bytes each when the machine has not
    that much available, before any work: one line with the estimate (``label`` replaces the opening
    ``<option> <count>``)."""
    need = count * bytes_each
    have = available_memory()
    if need > have:
        raise TognetError(
            f"{label or f'{option} {count}'}: would hold about {human_bytes(need)} in memory ({what}), but "
            f"this machine has {human_bytes(have)} available; ask for fewer")


def check_disk(option: str, count: int, bytes_each: float, folder: Path, what: str = "episode",
               label: str | None = None) -> None:
    """Refuse ``count`` items of about ``bytes_each`` bytes when the disk holding ``folder`` cannot take
    them, before any is written: one line with the estimate, what is free and the shortfall (how much more
    is needed than is free); ``label`` replaces the opening ``<option> <count>``."""
    need = count * bytes_each
    free = shutil.disk_usage(_existing_ancestor(folder)).free
    if need > free:
        raise TognetError(
            f"{label or f'{option} {count}'}: would need about {human_bytes(need)} (about "
            f"{human_bytes(bytes_each)} per {what}), but the disk holding {folder} has {human_bytes(free)} "
            f"free, about {human_bytes(need - free)} short; ask for fewer or free space")
