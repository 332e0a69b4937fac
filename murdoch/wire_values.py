"""Field values of wire messages: checked against their annotations and converted.

`compile_converter` makes, once per field, the function that checks a decoded JSON value
against the field's annotation and returns its message form (`freeze`: lists to tuples,
objects to read-only mappings); `thaw` is the way back. The pattern pieces and scalar readers
below let `murdoch.wire.Codec` read flat bodies (scalar fields, a few compact containers)
without the JSON decoder. `WireError` is what every check raises.
"""

from __future__ import annotations

import json
import math
import re
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from typing import Any

FLAT_HINTS = (str, int, float, bool, type(None))
FLAT_VALUE = (
    rb'("[^"\\\x00-\x1f]*"|-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][-+]?[0-9]+)?'
    rb"|null|true|false)"
)
"""One JSON scalar in the compact form senders write: a string without escapes, a number,
null, true or false (anything else goes through the JSON decoder)."""
FlatReader = Callable[[bytes, int, int], "list[Any] | None"]
FlatBuilder = Callable[[bytes, int, int], Any]




class WireError(ValueError):
    """A datagram or message that cannot be encoded or decoded; `reason` names the counter."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason
        self.detail = detail




def freeze(value: Any) -> Any:
    """Lists to tuples and dicts to read-only mappings, all the way down."""
    if isinstance(value, list):
        return tuple(freeze(v) for v in value)
    if isinstance(value, dict):
        return types.MappingProxyType({k: freeze(v) for k, v in value.items()})
    return value


_PLAIN = (str, int, bool, type(None))


def thaw(value: Any) -> Any:
    if type(value) in _PLAIN:
        return value
    if isinstance(value, Mapping):
        return {str(k): thaw(v) for k, v in value.items()}
    if isinstance(value, tuple | list | frozenset | set):
        items = sorted(value) if isinstance(value, frozenset | set) else value
        return [thaw(v) for v in items]
    if isinstance(value, float) and not math.isfinite(value):
        raise WireError("bad_fields", f"non-finite number {value!r}")
    return value


Converter = Callable[[Any], Any]


def _fail(name: str, expected: str, value: Any) -> WireError:
    return WireError("bad_fields", f"{name}: expected {expected}, found {value!r}"[:200])


#: scalar annotations a JSON value must match exactly (no bool for int), with their error names
_EXACT_SCALARS: dict[Any, str] = {int: "int", str: "string"}


def _exact_scalar(kind: type, name: str) -> Converter:
    expected = _EXACT_SCALARS[kind]

    def convert_exact(value: Any) -> Any:
        if type(value) is kind:
            return value
        raise _fail(name, expected, value)

    return convert_exact


def compile_converter(hint: Any, name: str) -> Converter:
    """A function that checks a decoded JSON value against `hint` and returns its message form."""
    if hint is Any:
        return freeze
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        options = [compile_converter(arg, name) for arg in args]
        accepts_none = type(None) in args

        def convert_union(value: Any) -> Any:
            if value is None and accepts_none:
                return None
            for option in options:
                try:
                    return option(value)
                except WireError:
                    continue
            raise _fail(name, str(hint), value)

        return convert_union
    if hint is type(None):

        def convert_none(value: Any) -> Any:
            if value is None:
                return None
            raise _fail(name, "null", value)

        return convert_none
    if hint is bool:

        def convert_bool(value: Any) -> Any:
            if value is True or value is False:
                return value
            raise _fail(name, "bool", value)

        return convert_bool
    if hint is int or hint is str:
        return _exact_scalar(hint, name)
    if hint is float:

        def convert_float(value: Any) -> Any:
            kind = type(value)
            if kind is float:
                if math.isfinite(value):
                    return value
            elif kind is int:
                try:
                    return float(value)
                except OverflowError:
                    pass
            raise _fail(name, "finite number", value)

        return convert_float
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            item = compile_converter(args[0], name)

            def convert_seq(value: Any) -> Any:
                if type(value) is not list:
                    raise _fail(name, "list", value)
                return tuple([item(v) for v in value])

            return convert_seq
        items = [compile_converter(a, name) for a in args]

        def convert_fixed(value: Any) -> Any:
            if type(value) is not list or len(value) != len(items):
                raise _fail(name, f"list of {len(items)}", value)
            return tuple([c(v) for c, v in zip(items, value, strict=True)])

        return convert_fixed
    if origin in (Mapping, dict) or hint in (Mapping, dict):

        def convert_map(value: Any) -> Any:
            if type(value) is not dict:
                raise _fail(name, "object", value)
            return freeze(value)

        return convert_map
    raise TypeError(f"{name}: annotation {hint} cannot be carried on the wire")




def _finite_float(token: bytes) -> float:
    value = float(token)
    if value - value != 0.0:
        raise ValueError("not finite")
    return value


def _json_bool(token: bytes) -> bool:
    return token == b"true"


def then(first: Callable[[bytes], Any], second: Converter) -> Callable[[bytes], Any]:
    return lambda token: second(first(token))


_NUMBER = rb"(-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][-+]?[0-9]+)?)"
TYPED_PIECES: dict[Any, tuple[bytes, Callable[[bytes], Any]]] = {
    str: (rb'"([^"\\\x00-\x1f]*)"', bytes.decode),
    int: (rb"(-?(?:0|[1-9][0-9]*))", int),
    float: (_NUMBER, _finite_float),
    bool: (rb"(true|false)", _json_bool),
}
"""Pattern pieces that admit only JSON values of one field type (strings without escapes),
with the builtin that makes the value."""


def _strings(token: bytes | None) -> tuple[str, ...]:
    if token is None:
        return ()
    return tuple([part.decode() for part in token[1:-1].split(b'","')])


def _no_members(token: bytes) -> Mapping[str, Any]:
    del token
    return types.MappingProxyType({})


def _no_items(token: bytes) -> tuple[()]:
    del token
    return ()


COMPACT_PIECES: dict[Any, tuple[bytes, Callable[[Any], Any]]] = {
    tuple[str, ...]: (rb'\[("[^"\\\x00-\x1f]*"(?:,"[^"\\\x00-\x1f]*")*)?\]', _strings),
    Mapping[str, Any]: (rb"(\{\})", _no_members),
    tuple[tuple[str, float], ...]: (rb"(\[\])", _no_items),
}
"""Containers read without the JSON decoder in their common compact forms: a list of
strings without escapes, an empty object (no parameters), an empty list (no metrics); any
other value of these fields goes through the decoder."""


def is_flat(hint: Any) -> bool:
    """Whether values of `hint` are JSON scalars (str, int, float, bool, None, unions)."""
    if hint in FLAT_HINTS:
        return True
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return all(arg in FLAT_HINTS for arg in typing.get_args(hint))
    return False


def json_scalar(token: bytes) -> Any:
    """The value of one token matched by `FLAT_VALUE`, as `json` would decode it."""
    first = token[0]
    if first == 0x22:  # '"': no escapes inside (the pattern allows none)
        return token[1:-1].decode("utf-8")
    if token == b"null":
        return None
    if token == b"true":
        return True
    if token == b"false":
        return False
    if b"." in token or b"e" in token or b"E" in token:
        return float(token)
    return int(token)


def json_string(value: str) -> str:
    """`value` as a JSON string, exactly as the (ASCII-only) JSON encoder writes it."""
    if value.isascii() and value.isprintable() and '"' not in value and "\\" not in value:
        return f'"{value}"'
    written: str = json.encoder.encode_basestring_ascii(value)
    return written


def reject_constant(name: str) -> Any:
    raise WireError("malformed", f"constant {name}")


def unique_members(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result = dict(pairs)
    if len(result) != len(pairs):
        raise WireError("malformed", "repeated member name")
    return result


def flat_reader(names: Sequence[str]) -> FlatReader:
    """Reads the values of a scalar-only body in the compact form (its fields in
    declaration order); None for any other form, which the JSON decoder then judges."""
    pattern = re.compile(
        rb"\{" + b",".join(b'"%s":' % n.encode("ascii") + FLAT_VALUE for n in names)
        + rb"\}"
    )
    fullmatch = pattern.fullmatch
    scalar = json_scalar

    def read(data: bytes, start: int, end: int) -> list[Any] | None:
        found = fullmatch(data, start, end)
        if found is None:
            return None
        try:
            return [scalar(token) for token in found.groups()]
        except ValueError:  # undecodable text, or an integer too long for int()
            return None  # the JSON decoder reports it

    return read


def flat_builder(cls: type, kind: str, converters: Mapping[str, Converter]) -> FlatBuilder:
    """Reads a scalar-only body in the compact form straight into a message: one
    pattern whose pieces admit only values of each field's type, each converted by a
    builtin (the general path handles any other form and every error's wording)."""
    hints = typing.get_type_hints(cls)
    pieces = []
    readers: list[Callable[[bytes], Any]] = []
    for name, convert in converters.items():
        hint = hints[name]
        piece, reader = TYPED_PIECES.get(hint) or COMPACT_PIECES.get(hint) or (None, None)
        if piece is None or reader is None:
            piece, reader = FLAT_VALUE, then(json_scalar, convert)
        pieces.append(b'"%s":' % name.encode("ascii") + piece)
        readers.append(reader)
    fullmatch = re.compile(rb"\{" + b",".join(pieces) + rb"\}").fullmatch
    typed = tuple(readers)

    def build(data: bytes, start: int, end: int) -> Any:
        found = fullmatch(data, start, end)
        if found is None:
            return None
        try:
            values = [read(token) for read, token in zip(typed, found.groups(), strict=True)]
        except ValueError:
            return None  # the general path says what is wrong
        try:
            return cls(*values)
        except (TypeError, ValueError, OverflowError) as exc:
            if isinstance(exc, WireError):
                raise
            raise WireError("bad_fields", f"{kind}: {exc}") from None

    return build
