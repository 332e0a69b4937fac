"""The JSON wire format shared by every transport.

One datagram is one UTF-8 JSON object::

    {"v": 1, "k": "<kind>", "s": "<sender id>", "i": "<instance>", "q": <sequence>,
     "t": ["<subject>", ...], "b": {<the message's fields>}}

`i` is a nonce chosen when a transport is opened, so a process that restarts under the same
sender id is a new (sender, instance) pair whose sequence numbers start again at 0.

With a team key (see `murdoch.auth`) the object starts with ``"h": "<hmac hex>"`` computed over
the exact bytes of the rest. Messages are frozen dataclasses with a class attribute ``KIND``; a
`Codec` is built from the message classes a process understands (no global registry), so any
package can add its own kinds by passing its classes in. Field values are checked against the
dataclass annotations on decode: str, int, float, bool, None, ``X | None``, ``tuple[X, ...]``,
fixed tuples and ``Mapping[str, Any]``. Lists decode to tuples, objects to read-only mappings.

Anything that does not fit raises `WireError` with a short ``reason`` used as a counter name
(``malformed``, ``bad_version``, ``unknown_kind``, ``bad_fields``, ``too_large``).
"""

from __future__ import annotations

import dataclasses
import json
import math
import types
import typing
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

from murdoch.subjects import SubjectError, SubjectSet, subject_set

WIRE_VERSION = 1
MAX_DATAGRAM_BYTES = 1400
"""Hard limit; typical auction messages are 150-350 bytes."""


class WireError(ValueError):
    """A datagram or message that cannot be encoded or decoded; `reason` names the counter."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason
        self.detail = detail


class Message(Protocol):
    """What a message class looks like: a frozen dataclass with a KIND."""

    KIND: ClassVar[str]


@dataclass(frozen=True)
class Envelope:
    """A received message with its addressing and transport facts."""

    sender: str
    seq: int
    subjects: SubjectSet
    message: Any
    size_bytes: int
    received_at: float

    @property
    def kind(self) -> str:
        return str(self.message.KIND)


@dataclass(frozen=True)
class Frame:
    """The decoded outer fields of a datagram before its body becomes a message."""

    kind: str
    sender: str
    seq: int
    subjects: SubjectSet
    body: Mapping[str, Any]
    instance: str = ""


def freeze(value: Any) -> Any:
    """Lists to tuples and dicts to read-only mappings, all the way down."""
    if isinstance(value, list):
        return tuple(freeze(v) for v in value)
    if isinstance(value, dict):
        return types.MappingProxyType({k: freeze(v) for k, v in value.items()})
    return value


_PLAIN = (str, int, bool, type(None))


def _thaw(value: Any) -> Any:
    if type(value) in _PLAIN:
        return value
    if isinstance(value, Mapping):
        return {str(k): _thaw(v) for k, v in value.items()}
    if isinstance(value, tuple | list | frozenset | set):
        items = sorted(value) if isinstance(value, frozenset | set) else value
        return [_thaw(v) for v in items]
    if isinstance(value, float) and not math.isfinite(value):
        raise WireError("bad_fields", f"non-finite number {value!r}")
    return value


Converter = Callable[[Any], Any]


def _fail(name: str, expected: str, value: Any) -> WireError:
    return WireError("bad_fields", f"{name}: expected {expected}, found {value!r}"[:200])


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
    if hint is int:

        def convert_int(value: Any) -> Any:
            if type(value) is int:
                return value
            raise _fail(name, "int", value)

        return convert_int
    if hint is float:

        def convert_float(value: Any) -> Any:
            kind = type(value)
            if kind is float:
                if math.isfinite(value):
                    return value
            elif kind is int:
                return float(value)
            raise _fail(name, "finite number", value)

        return convert_float
    if hint is str:

        def convert_str(value: Any) -> Any:
            if type(value) is str:
                return value
            raise _fail(name, "string", value)

        return convert_str
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


class Codec:
    """Encodes and decodes the message classes it was built with."""

    def __init__(
        self, message_types: Iterable[type], max_datagram_bytes: int = MAX_DATAGRAM_BYTES
    ) -> None:
        self.max_datagram_bytes = max_datagram_bytes
        self._types: dict[str, type] = {}
        self._converters: dict[str, dict[str, Converter]] = {}
        self._field_names: dict[str, frozenset[str]] = {}
        self._field_order: dict[str, tuple[str, ...]] = {}
        self._subject_cache: dict[tuple[str, ...], SubjectSet] = {}
        self._decoder = json.JSONDecoder(parse_constant=_reject_constant)
        self._encoder = json.JSONEncoder(separators=(",", ":"), allow_nan=False)
        for cls in message_types:
            if not dataclasses.is_dataclass(cls):
                raise TypeError(f"{cls.__name__} is not a dataclass")
            kind = getattr(cls, "KIND", None)
            if not isinstance(kind, str) or not kind:
                raise TypeError(f"{cls.__name__} has no KIND")
            if kind in self._types and self._types[kind] is not cls:
                raise TypeError(f"two message classes share the kind {kind!r}")
            hints = typing.get_type_hints(cls)
            self._types[kind] = cls
            names = [f.name for f in dataclasses.fields(cls)]
            self._converters[kind] = {n: compile_converter(hints[n], n) for n in names}
            self._field_names[kind] = frozenset(names)
            self._field_order[kind] = tuple(names)

    @property
    def kinds(self) -> frozenset[str]:
        return frozenset(self._types)

    def knows(self, kind: str) -> bool:
        return kind in self._types

    def extended(self, message_types: Iterable[type]) -> Codec:
        """A codec that also knows `message_types`."""
        return Codec([*self._types.values(), *message_types], self.max_datagram_bytes)

    def body_of(self, message: Any) -> dict[str, Any]:
        kind = getattr(message, "KIND", None)
        if not isinstance(kind, str) or not isinstance(message, self._types.get(kind, ())):
            raise WireError("unknown_kind", f"{type(message).__name__} is not in this codec")
        return {name: _thaw(getattr(message, name)) for name in self._field_order[kind]}

    def encode_frame(
        self, sender: str, seq: int, subjects: SubjectSet, message: Any, instance: str = ""
    ) -> bytes:
        """The unauthenticated datagram bytes of one message."""
        obj = {
            "v": WIRE_VERSION,
            "k": message.KIND,
            "s": sender,
            "i": instance,
            "q": seq,
            "t": sorted(subjects),
            "b": self.body_of(message),
        }
        try:
            data = self._encoder.encode(obj).encode("utf-8")
        except (TypeError, ValueError) as exc:
            raise WireError("bad_fields", f"{message.KIND}: {exc}") from None
        if len(data) > self.max_datagram_bytes:
            raise WireError(
                "too_large", f"{message.KIND} is {len(data)} bytes > {self.max_datagram_bytes}"
            )
        return data

    def parse_frame(self, data: bytes) -> Frame:
        """Decode the outer fields; the body is checked by `message_of`."""
        if len(data) > self.max_datagram_bytes:
            raise WireError("too_large", f"{len(data)} bytes")
        try:
            obj = self._decoder.decode(data.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError, WireError) as exc:
            raise WireError("malformed", f"not JSON: {exc}") from None
        if not isinstance(obj, dict):
            raise WireError("malformed", "datagram is not a JSON object")
        if obj.get("v") != WIRE_VERSION:
            raise WireError("bad_version", f"version {obj.get('v')!r}")
        kind = obj.get("k")
        sender = obj.get("s")
        seq = obj.get("q")
        subjects = obj.get("t")
        body = obj.get("b")
        instance = obj.get("i", "")
        if type(kind) is not str or type(sender) is not str or not sender:
            raise WireError("malformed", "kind or sender missing")
        if type(instance) is not str:
            raise WireError("malformed", f"bad instance {instance!r}")
        if type(seq) is not int or seq < 0:
            raise WireError("malformed", f"bad sequence {seq!r}")
        if type(subjects) is not list or type(body) is not dict:
            raise WireError("malformed", "subjects or body missing")
        return Frame(kind, sender, seq, self._subjects_of(subjects), body, instance)

    def _subjects_of(self, subjects: list[Any]) -> SubjectSet:
        key = tuple(subjects)
        cached = self._subject_cache.get(key)
        if cached is not None:
            return cached
        try:
            result = subject_set(subjects)
        except (SubjectError, TypeError) as exc:
            raise WireError("malformed", str(exc)) from None
        if len(self._subject_cache) >= 4096:
            self._subject_cache.clear()
        self._subject_cache[key] = result
        return result

    def message_of(self, frame: Frame) -> Any:
        cls = self._types.get(frame.kind)
        if cls is None:
            raise WireError("unknown_kind", f"kind {frame.kind!r}")
        converters = self._converters[frame.kind]
        body = frame.body
        if len(body) != len(converters) or not self._field_names[frame.kind].issuperset(body):
            raise WireError(
                "bad_fields", f"{frame.kind} fields {sorted(body)} != {sorted(converters)}"
            )
        values = {name: convert(body[name]) for name, convert in converters.items()}
        try:
            return cls(**values)
        except (TypeError, ValueError) as exc:
            raise WireError("bad_fields", f"{frame.kind}: {exc}") from None


def _reject_constant(name: str) -> Any:
    raise WireError("malformed", f"constant {name}")
