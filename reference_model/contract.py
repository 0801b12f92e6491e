"""The learned-model contract, torch-free: a model's **kind** and the config base.

Every learned model has one :class:`Kind` (what its inference writes, and so which verb runs
it) and one config, a frozen dataclass that subclasses :class:`ModelConfig`. A config
subclass registers itself (:data:`CONFIGS`) and checks its values on construction: every
field against its annotated type (``int``, ``float``, ``bool``, ``str``, ``X | None``,
``tuple[...]``), then the subclass's own :meth:`ModelConfig.validate`. ``train --set
KEY=VALUE`` parses VALUE by the field's type (:meth:`ModelConfig.with_overrides`).

The torch half of the contract (loading, training, inference) is
:mod:`nsrmp_bench.reference_model.base`.
"""

from __future__ import annotations

import dataclasses
import json
import types
import typing
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, TypeVar

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.predictors import Kind  # the kind of every predictor (one registry)

__all__ = ["CONFIGS", "Kind", "ModelConfig", "parse_value"]

C = TypeVar("C", bound="ModelConfig")


CONFIGS: dict[str, type[ModelConfig]] = {}
"""Every config class, by ``module.QualName`` (filled as the classes are defined)."""


def _type_name(tp: object) -> str:
    return getattr(tp, "__name__", None) or str(tp).replace("typing.", "")


def _check(value: Any, tp: Any) -> Any:
    """``value`` as a value of type ``tp`` (an int is taken for a float), else ValueError."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        for option in typing.get_args(tp):
            try:
                return _check(value, option)
            except ValueError:
                continue
        raise ValueError
    if tp is type(None):
        if value is None:
            return None
        raise ValueError
    if origin is tuple:
        args = typing.get_args(tp)
        if not isinstance(value, (tuple, list)):
            raise ValueError
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_check(v, args[0]) for v in value)
        if len(args) != len(value):
            raise ValueError
        return tuple(_check(v, a) for v, a in zip(value, args, strict=True))
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise ValueError
    if tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise ValueError
    if tp is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        raise ValueError
    if tp is str:
        if isinstance(value, str):
            return value
        raise ValueError
    msg = f"config fields of type {_type_name(tp)} are not supported"
    raise TypeError(msg)


_TRUE = frozenset({"true", "yes", "1", "on"})
_FALSE = frozenset({"false", "no", "0", "off"})


def parse_value(text: str, tp: Any) -> Any:
    """The value ``text`` means for a field of type ``tp``, else ValueError.

    ``bool``: true/false, yes/no, 1/0, on/off; ``X | None``: ``none`` (or ``null``) or an X;
    ``tuple[...]``: comma-separated items (``3,4``; empty text is the empty tuple)."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        options = typing.get_args(tp)
        if type(None) in options and text.strip().lower() in ("none", "null"):
            return None
        for option in options:
            if option is type(None):
                continue
            try:
                return parse_value(text, option)
            except ValueError:
                continue
        raise ValueError
    if origin is tuple:
        args = typing.get_args(tp)
        parts = [p.strip() for p in text.split(",")] if text.strip() else []
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(parse_value(p, args[0]) for p in parts)
        if len(parts) != len(args):
            raise ValueError
        return tuple(parse_value(p, a) for p, a in zip(parts, args, strict=True))
    if tp is bool:
        low = text.strip().lower()
        if low in _TRUE:
            return True
        if low in _FALSE:
            return False
        raise ValueError
    if tp is int:
        return int(text.strip())
    if tp is float:
        return float(text.strip())
    if tp is str:
        return text
    return _check(json.loads(text), tp)


class ModelConfig:
    """The base of every model's config: subclass it with ``@dataclass(frozen=True)``.

    A subclass has a ``threads: int`` field (torch threads, set explicitly before any
    work) and may override :meth:`validate` for checks across fields or of ranges.
    """

    _field_types: ClassVar[dict[str, Any]]

    ABSENT: ClassVar[Mapping[str, Any]] = {}
    """Values of fields added after checkpoints were shipped, as those checkpoints were
    trained (a field's default is what new runs use)."""

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        CONFIGS[f"{cls.__module__}.{cls.__qualname__}"] = cls

    @classmethod
    def field_types(cls) -> dict[str, Any]:
        """Each field's name and its (resolved) annotated type, in field order."""
        if "_field_types" not in cls.__dict__:
            hints = typing.get_type_hints(cls)
            cls._field_types = {f.name: hints[f.name] for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
        return cls._field_types

    def __post_init__(self) -> None:
        name = type(self).__qualname__
        for key, tp in self.field_types().items():
            value = getattr(self, key)
            try:
                checked = _check(value, tp)
            except ValueError:
                msg = (f"{name}.{key} = {value!r} is not a {_type_name(tp)}; pass a "
                       f"{_type_name(tp)} (the default is the shipped run's)")
                raise InvalidArgument(msg) from None
            if type(checked) is not type(value) or checked != value:
                object.__setattr__(self, key, checked)
        if "threads" not in self.field_types():
            msg = f"{name} has no field 'threads'; every model config states its torch threads"
            raise TypeError(msg)
        self.validate()

    def validate(self) -> None:
        """Checks of ranges and across fields; raise :class:`InvalidArgument` naming the
        field, the value and what is expected. The base checks ``threads >= 1``."""
        threads = getattr(self, "threads")  # noqa: B009 (a field of every subclass)
        if threads < 1:
            msg = f"{type(self).__qualname__}.threads = {threads} must be at least 1"
            raise InvalidArgument(msg)

    def require(self, ok: bool, key: str, expected: str) -> None:
        """Raise :class:`InvalidArgument` for field ``key`` unless ``ok``."""
        if not ok:
            msg = (f"{type(self).__qualname__}.{key} = {getattr(self, key)!r}: {expected}; "
                   f"pass --set {key}=VALUE with a value that is")
            raise InvalidArgument(msg)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (field order)."""
        return dataclasses.asdict(self)  # type: ignore[call-overload, no-any-return]

    @classmethod
    def from_dict(cls: type[C], data: Mapping[str, Any]) -> C:
        """Inverse of :meth:`to_dict`; an unknown key is an error, and a key the dict
        lacks takes its :attr:`ABSENT` value (what checkpoints from before the field was
        added were trained with), else its default."""
        data = {**cls.ABSENT, **data}
        unknown = sorted(set(data) - set(cls.field_types()))
        if unknown:
            msg = (f"{cls.__qualname__} has no field(s) {unknown}; its fields are "
                   f"{', '.join(cls.field_types())}")
            raise InvalidArgument(msg)
        return cls(**data)

    def with_overrides(self: C, items: Sequence[str], model: str = "") -> C:
        """This config with ``KEY=VALUE`` overrides (``train --set``), each VALUE parsed by
        its field's type; an unknown key or a bad value is an :class:`InvalidArgument`."""
        types_ = self.field_types()
        whose = f"{model}'s config" if model else type(self).__qualname__
        changes: dict[str, Any] = {}
        for item in items:
            key, sep, text = item.partition("=")
            key = key.strip()
            if not sep or key not in types_:
                msg = (f"--set {item!r} is not KEY=VALUE with a field of {whose}; "
                       f"fields: {', '.join(types_)}")
                raise InvalidArgument(msg)
            tp = types_[key]
            try:
                changes[key] = parse_value(text, tp)
            except (ValueError, json.JSONDecodeError):
                msg = (f"--set {item!r}: {text!r} is not a {_type_name(tp)} (the type of "
                       f"{key}, default {getattr(self, key)!r})")
                raise InvalidArgument(msg) from None
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def differences(self, other: Mapping[str, Any]) -> list[str]:
        """The keys whose values differ between this config and ``other`` (a config dict,
        e.g. a run's ``config.json``), sorted."""
        mine = json.loads(json.dumps(self.to_dict()))
        keys = set(mine) | set(other)
        return sorted(k for k in keys if mine.get(k, _MISSING) != other.get(k, _MISSING))


_MISSING = object()
