"""Where vehloc's configs live, installed or not, and typed parameter objects built from them.

Every tunable has one home, a YAML file under `conf/`; the parameter dataclasses of the library carry no
defaults of their own and are built from those files (`params_from_config`), with the value types checked
against the dataclass's annotations, so a wrong setting is named in one line before any work starts."""

from __future__ import annotations

import argparse
import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

import yaml

from vehloc.errors import VehlocError

T = TypeVar("T")


class ConfigError(VehlocError):
    """A setting is unknown, missing, of the wrong type or out of range."""


class SettingError(ValueError):
    """Raised by a parameter dataclass's `__post_init__` for one bad setting; `build_params` names it in full
    (`data.batch_size: must be >= 1, got 0`)."""

    def __init__(self, setting: str, message: str) -> None:
        super().__init__(f"{setting}: {message}")
        self.setting = setting
        self.message = message


def check_range(
    name: str, value: float, low: float | None = None, high: float | None = None,
    low_open: bool = False, high_open: bool = False,
) -> None:
    """SettingError unless `low <= value <= high` (`<` on an open side; None: unbounded)."""
    too_low = low is not None and (value <= low if low_open else value < low)
    too_high = high is not None and (value >= high if high_open else value > high)
    if too_low or too_high:
        if low is not None and high is not None:
            bounds = f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
        elif low is not None:
            bounds = f"{'>' if low_open else '>='} {low:g}"
        else:
            bounds = f"{'<' if high_open else '<='} {high:g}"
        raise SettingError(name, f"must be {bounds}, got {value!r}")


def check_interval(name: str, interval: tuple[float, float], low: float | None = None,
                   high: float | None = None, low_open: bool = False) -> None:
    """SettingError unless `interval` is an ordered pair inside [low, high]: `low <= interval[0] <= interval[1] <=
    high` (`low < interval[0]` with `low_open`; None: unbounded)."""
    check_range(f"{name}[0]", interval[0], low, high, low_open=low_open)
    check_range(f"{name}[1]", interval[1], interval[0], high)


def check_choice(name: str, value: object, choices: tuple) -> None:
    """SettingError unless `value` is one of `choices`."""
    if value not in choices:
        raise SettingError(name, f"expected one of {', '.join(map(str, choices))}, got {value!r}")


def config_dir() -> Path:
    """The folder of vehloc's Hydra configs: the repository's `conf/`, installed with the package as
    `vehloc.conf` (editable or not)."""
    return Path(str(resources.files("vehloc.conf")))


def read_config(relative_path: str) -> dict[str, Any]:
    """One YAML file of `conf/` as plain data, e.g. `read_config("localize/roi/default.yaml")`."""
    path = config_dir() / relative_path
    try:
        content = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        raise ConfigError(f"{path}: not a readable YAML config ({type(err).__name__})") from None
    if not isinstance(content, dict):
        raise ConfigError(f"{path}: expected a mapping of settings")
    return content


def params_from_config(cls: type[T], relative_path: str, overrides: Mapping[str, Any] | None = None) -> T:
    """The dataclass `cls` from `conf/<relative_path>`, with `overrides` (nested mappings for nested
    dataclasses) replacing single settings."""
    values = _merged(read_config(relative_path), dict(overrides or {}))
    return build_params(cls, values, Path(relative_path).parent.name or relative_path)


def _merged(base: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    merged = dict(base)
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            merged[key] = _merged(dict(merged[key]), dict(value))
        else:
            merged[key] = value
    return merged


def build_params(cls: type[T], values: Mapping[str, Any], where: str) -> T:
    """The dataclass `cls` from a mapping, every value checked against the field's annotation;
    ConfigError naming the setting (`where.name`; `where` "" for top-level settings) otherwise."""
    if not isinstance(values, Mapping):
        raise ConfigError(f"{where or 'settings'}: expected a mapping of settings, got {values!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise ConfigError(f"{where or 'settings'}: unknown setting(s) {', '.join(unknown)} (known: {', '.join(fields)})")
    required = [name for name, f in fields.items()
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    missing = [name for name in required if name not in values]
    if missing:
        raise ConfigError(f"{where or 'settings'}: missing setting(s) {', '.join(missing)}")
    kwargs = {name: _coerce(hints[name], value, _joined(where, name)) for name, value in values.items()}
    try:
        return cls(**kwargs)
    except SettingError as err:
        raise ConfigError(f"{_joined(where, err.setting)}: {err.message}") from None
    except ValueError as err:
        raise ConfigError(f"{where or 'settings'}: {err}") from None


def _joined(where: str, name: str) -> str:
    """`where.name`, or `name` for the top level (`where` "")."""
    return f"{where}.{name}" if where else name


def _coerce(annotation: Any, value: Any, where: str) -> Any:
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        kinds = [a for a in args if a is not type(None)]
        errors = []
        for kind in kinds:
            try:
                return _coerce(kind, value, where)
            except ConfigError as err:
                errors.append(str(err))
        raise ConfigError(errors[0])
    if dataclasses.is_dataclass(annotation):
        return build_params(annotation, value, where)
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{where}: expected a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_coerce(args[0], v, f"{where}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ConfigError(f"{where}: expected {len(args)} values, got {len(value)}")
        return tuple(_coerce(kind, v, f"{where}[{i}]") for i, (kind, v) in enumerate(zip(args, value)))
    if annotation is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where}: expected true or false, got {value!r}")
        return value
    if annotation is int:
        if isinstance(value, bool) or not (isinstance(value, int) or (isinstance(value, float) and value.is_integer())):
            raise ConfigError(f"{where}: expected an integer, got {value!r}")
        return int(value)
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"{where}: expected a finite number, got {value!r}")
        return float(value)
    if annotation is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: expected a string, got {value!r}")
        return value
    return value


class ArgumentParser(argparse.ArgumentParser):
    """argparse for vehloc's console scripts: a bad argument is one line, `<prog>: error: <what>`, exit code 2
    (without argparse's usage block; `--help` shows it)."""

    def error(self, message: str) -> typing.NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def integer_argument(low: int | None = None, high: int | None = None) -> typing.Callable[[str], int]:
    """An argparse `type` for an integer in [low, high]; its error names the value and the range."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if (low is not None and value < low) or (high is not None and value > high):
            bounds = f">= {low}" if high is None else f"<= {high}" if low is None else f"from {low} to {high}"
            raise argparse.ArgumentTypeError(f"expected an integer {bounds}, got {value}")
        return value

    parse.__name__ = "integer"
    return parse


def positive_number_argument(text: str) -> float:
    """An argparse `type` for a finite number above 0; its error names the value."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number above 0, got {text}")
    return value
