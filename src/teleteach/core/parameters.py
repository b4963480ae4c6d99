"""A node's parameters as a dataclass, built one way: every value from a mapping, none from code.

The mapping is the node's yaml, overridden by the parameter server; a missing or unknown key is named in one line.

The yaml in config/ is the one place of the values: a default a dataclass declares in code is never used by a node
(every field must be in the mapping, but those the caller names as not parameters, e.g. a cache folder).
"""

import dataclasses
import typing

T = typing.TypeVar("T")


def from_mapping(
    cls: typing.Type[T],
    values: typing.Mapping[str, typing.Any],
    where: str,
    error: typing.Type[ValueError] = ValueError,
    optional: typing.Collection[str] = (),
) -> T:
    """``cls`` built from ``values``, every field named there but the ``optional`` ones (not parameters).

    Lists become tuples and whole numbers floats where the field says so, a mapping the nested dataclass of its field.

    Raises ``error`` (a ValueError) saying ``<where>: missing a, b; unknown c``, with nested keys as ``section/key``,
    or ``<where>: <why>`` when ``cls`` refuses a value (its own ``error`` passes unchanged).
    """
    problems = key_problems(cls, values, optional)
    if problems:
        raise error(f"{where}: {problems}")
    hints = typing.get_type_hints(cls)
    try:
        return cls(**{name: _typed(value, hints[name], f"{where}/{name}", error) for name, value in values.items()})
    except error:
        raise
    except (TypeError, ValueError) as refused:
        raise error(f"{where}: {refused}") from None


def key_problems(
    cls: typing.Type[typing.Any],
    values: typing.Mapping[str, typing.Any],
    optional: typing.Collection[str] = (),
    prefix: str = "",
) -> str:
    """``missing a, b; unknown c`` for the keys of ``values`` against the fields of ``cls`` (nested too), or ""."""
    fields = {field.name: field for field in dataclasses.fields(cls) if field.init}
    hints = typing.get_type_hints(cls)
    missing = [prefix + name for name in fields if name not in values and name not in optional]
    unknown = [prefix + name for name in values if name not in fields]
    nested = [
        key_problems(hints[name], value, prefix=f"{prefix}{name}/")
        for name, value in values.items()
        if name in fields and dataclasses.is_dataclass(hints[name]) and isinstance(value, typing.Mapping)
    ]
    said = [f"missing {', '.join(missing)}" if missing else "", f"unknown {', '.join(unknown)}" if unknown else ""]
    return "; ".join(filter(None, [*said, *nested]))


def _typed(value: typing.Any, hint: typing.Any, where: str, error: typing.Type[ValueError]) -> typing.Any:
    if dataclasses.is_dataclass(hint) and isinstance(value, typing.Mapping):
        return from_mapping(hint, value, where, error)
    if (hint is tuple or typing.get_origin(hint) is tuple) and isinstance(value, (list, tuple)):
        return tuple(value)
    if hint is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value
