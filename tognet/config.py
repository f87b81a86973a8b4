"""Typed configuration: dataclasses whose every field carries a docstring.

Configs are saved as JSON next to every dataset, checkpoint and result, and loaded back strictly:
an unknown key (a typo) or a value of the wrong type is a :class:`ConfigError` that names the key.

Declare a config like this::

    @dataclass(frozen=True)
    class CameraNoise(Config):
        sigma: float = doc(0.001, "Std-dev of additive depth noise (m).", ge=0)

Values are range-checked when a config is made, loaded or replaced: ``gt``/``ge``/``lt``/``le`` bounds
given to :func:`doc` (applied to every element of a tuple), numbers that are not finite, and seeds (a
field named ``seed`` or ``*_seed``) below 0; a :meth:`Config.check` override adds checks that involve
several fields. The error names the field (and the file it came from).
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import types
import typing
from pathlib import Path
from typing import Any, Self

from tognet.io import atomic_write_text


class ConfigError(ValueError):
    """A config file or dict does not match its declared type."""


class ConfigRangeError(ConfigError):
    """A config value outside its field's range; ``field`` and ``rule`` let a loader name the file."""

    def __init__(self, owner: str, field: str, rule: str) -> None:
        super().__init__(f"{owner}.{field} {rule}")
        self.field = field
        self.rule = rule


def doc(default: Any = dataclasses.MISSING, text: str = "", *, factory: Any = dataclasses.MISSING,
        gt: float | None = None, ge: float | None = None, lt: float | None = None,
        le: float | None = None, omit_default: bool = False) -> Any:
    """A dataclass field with a docstring (``text``), kept in the field's metadata, and optional bounds
    on its value (``gt`` > , ``ge`` >=, ``lt`` <, ``le`` <=; each element of a tuple or list).

    ``omit_default``: the field is left out of the saved JSON while it holds its default (a field added
    to a config whose files must stay byte for byte the same; loading a file without it gives the
    default)."""
    if not text:
        raise TypeError("every config field needs a docstring")
    metadata: dict[str, Any] = {"doc": text}
    if omit_default:
        metadata["omit_default"] = True
    bounds = {k: v for k, v in (("gt", gt), ("ge", ge), ("lt", lt), ("le", le)) if v is not None}
    if bounds:
        metadata["bounds"] = bounds
    if factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=factory, metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def _numbers(value: Any) -> list[float]:
    if isinstance(value, bool):
        return []
    if isinstance(value, int | float):
        return [value]
    if isinstance(value, tuple | list):
        return [v for item in value for v in _numbers(item)]
    return []


def _rule(bounds: dict[str, float]) -> str:
    if set(bounds) == {"gt"} and bounds["gt"] == 0:
        return "must be positive"
    if set(bounds) == {"ge"} and bounds["ge"] == 0:
        return "must be 0 or more"
    low = f"> {bounds['gt']:g}" if "gt" in bounds else (f">= {bounds['ge']:g}" if "ge" in bounds else "")
    high = f"< {bounds['lt']:g}" if "lt" in bounds else (f"<= {bounds['le']:g}" if "le" in bounds else "")
    return "must be " + " and ".join(x for x in (low, high) if x)


def check_ranges(config: Any) -> None:
    """Raise :class:`ConfigRangeError` for the first field of ``config`` (a dataclass) out of its range:
    its :func:`doc` bounds, a number that is not finite, a negative seed."""
    owner = type(config).__name__
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        numbers = _numbers(value)
        if not numbers:
            continue
        shown = value if not isinstance(value, list) else tuple(value)
        for x in numbers:
            if not math.isfinite(x):
                raise ConfigRangeError(owner, f.name, f"must be a finite number, got {shown}")
        bounds = f.metadata.get("bounds", {})
        if (f.name == "seed" or f.name.endswith("_seed")) and not bounds:
            bounds = {"ge": 0}
        for x in numbers:
            low = ("gt" in bounds and not x > bounds["gt"]) or ("ge" in bounds and not x >= bounds["ge"])
            high = ("lt" in bounds and not x < bounds["lt"]) or ("le" in bounds and not x <= bounds["le"])
            if low or high:
                unit = _unit(f.metadata.get("doc", ""))
                raise ConfigRangeError(owner, f.name, f"{_rule(bounds)}{unit}, got {shown}")


def _unit(text: str) -> str:
    """The unit a field's docstring gives in its first parentheses, as ' (m)', if it looks like one."""
    start = text.find("(")
    end = text.find(")", start)
    inside = text[start + 1:end] if start >= 0 and end > start else ""
    return f" ({inside})" if inside and len(inside) <= 12 else ""


def _convert(value: Any, annotation: Any, where: str) -> Any:
    """Convert a JSON value to ``annotation``, raising ConfigError naming ``where`` on mismatch."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if annotation is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(value, arg, where)
            except ConfigRangeError:
                raise
            except ConfigError as exc:
                errors.append(str(exc))
        if len(errors) == 1:
            raise ConfigError(errors[0])
        raise ConfigError(f"{where}: {value!r} matches none of {annotation}")
    if origin is typing.Literal:
        if value not in args:
            raise ConfigError(f"{where}: {value!r} is not one of {list(args)}")
        return value
    if isinstance(annotation, type) and dataclasses.is_dataclass(annotation):
        if not isinstance(value, dict):
            raise ConfigError(f"{where}: expected a mapping for {annotation.__name__}, got {value!r}")
        return _from_dict(annotation, value, where)
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise ConfigError(f"{where}: expected a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(v, args[0], f"{where}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ConfigError(f"{where}: expected {len(args)} values, got {len(value)}")
        pairs = enumerate(zip(value, args, strict=True))
        return tuple(_convert(v, a, f"{where}[{i}]") for i, (v, a) in pairs)
    if origin is list:
        if not isinstance(value, list | tuple):
            raise ConfigError(f"{where}: expected a list, got {value!r}")
        return [_convert(v, args[0] if args else Any, f"{where}[{i}]") for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, dict):
            raise ConfigError(f"{where}: expected a mapping, got {value!r}")
        return {k: _convert(v, args[1] if args else Any, f"{where}.{k}") for k, v in value.items()}
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{where}: expected a number, got {value!r}")
        return float(value)
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: expected an integer, got {value!r}")
        return value
    if annotation is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where}: expected true or false, got {value!r}")
        return value
    if annotation is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: expected a string, got {value!r}")
        return value
    return value


def _from_dict(cls: type, data: dict[str, Any], where: str) -> Any:
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = [k for k in data if k not in fields]
    if unknown:
        key = unknown[0]
        close = difflib.get_close_matches(key, list(fields), n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ConfigError(f"{where}: unknown key '{key}'{hint}; known keys: {', '.join(fields)}")
    kwargs = {name: _convert(value, hints[name], f"{where}.{name}") for name, value in data.items()}
    try:
        return cls(**kwargs)
    except ConfigRangeError as exc:
        raise ConfigError(f"{where}.{exc.field} {exc.rule}") from None
    except ConfigError:
        raise
    except ValueError as exc:  # a config's own __post_init__ check: say where the value came from
        raise ConfigError(f"{where}: {exc}") from None
    except TypeError as exc:
        raise ConfigError(f"{where}: {exc}") from exc


def _to_jsonable(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _to_jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)
                if not (f.metadata.get("omit_default") and getattr(value, f.name) == _default(f))}
    if isinstance(value, tuple | list):
        return [_to_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _to_jsonable(v) for k, v in value.items()}
    if hasattr(value, "tolist"):
        return value.tolist()
    return value


def _default(f: dataclasses.Field) -> Any:
    """A field's default value (from its factory if it has one)."""
    if f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
        return f.default_factory()  # type: ignore[misc]
    return f.default


class Config:
    """Mixin for dataclass configs: strict dict/JSON round-trip, range checks and self-description."""

    def __post_init__(self) -> None:
        check_ranges(self)
        self.check()

    def check(self) -> None:
        """Checks that involve several fields (override; raise :class:`ConfigRangeError`)."""

    def to_dict(self) -> dict[str, Any]:
        """The config as plain JSON-compatible data."""
        return _to_jsonable(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, where: str | None = None) -> Self:
        """Build from a dict; unknown keys and wrong types raise :class:`ConfigError`."""
        if not isinstance(data, dict):
            raise ConfigError(f"{where or cls.__name__}: expected a mapping, got {type(data).__name__}")
        return _from_dict(cls, data, where or cls.__name__)

    def save(self, path: str | Path) -> Path:
        """Write the config as indented JSON (tagged with its class name)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        payload = {"config_type": type(self).__name__, **self.to_dict()}
        atomic_write_text(path, json.dumps(payload, indent=2, sort_keys=False) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> Self:
        """Read a JSON config; a missing file, bad JSON or mismatched key raises ConfigError."""
        path = Path(path)
        if path.is_dir():
            raise ConfigError(f"{path}: is a folder, not a {cls.__name__} JSON file")
        if not path.is_file():
            raise ConfigError(f"config file not found: {path}")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except UnicodeDecodeError:
            raise ConfigError(f"{path}: not a text file (not UTF-8: binary?); a {cls.__name__} is a JSON "
                              "text file") from None
        except json.JSONDecodeError as exc:
            raise ConfigError(f"{path}: not valid JSON ({exc})") from exc
        if not isinstance(data, dict):
            raise ConfigError(f"{path}: expected a JSON object")
        kind = data.pop("config_type", cls.__name__)
        if kind != cls.__name__:
            raise ConfigError(f"{path}: holds a {kind}, expected a {cls.__name__}")
        return cls.from_dict(data, where=str(path))

    def replace(self, **changes: Any) -> Self:
        """A copy with some fields changed (validated like a loaded file)."""
        data = self.to_dict()
        for key, value in changes.items():
            data[key] = _to_jsonable(value)
        return type(self).from_dict(data)

    @classmethod
    def describe(cls) -> list[tuple[str, str, str]]:
        """(name, default, docstring) for each field, for help texts."""
        rows = []
        for f in dataclasses.fields(cls):  # type: ignore[arg-type]
            if f.default is not dataclasses.MISSING:
                default = repr(f.default)
            elif f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
                default = repr(f.default_factory())  # type: ignore[misc]
            else:
                default = "(required)"
            rows.append((f.name, default, f.metadata.get("doc", "")))
        return rows
