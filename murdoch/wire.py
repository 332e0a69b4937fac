"""The wire format shared by every transport (version 3): one JSON object per datagram.

A datagram is one UTF-8 JSON object with a header array and the message's fields::

    {"h":[3,"bid","r2","9c41d2e7",17,"task.user.5e1f07.4",1234,"e5"],"b":{"task_id":...}}

The header is `[version, kind, sender, instance, seq, subjects, tick, epoch]`: the wire
version (3), the message class's KIND, the sender id, an instance nonce drawn when a transport
is opened (``""`` for none; a process that restarts under the same sender id is a new
(sender, instance) pair whose sequence numbers start again at 0), the per-sender sequence
number, the subject set as one comma-separated, sorted string (``""`` for the empty set), the
sender's simulation tick when it sent the datagram (``-1``: the sender keeps no simulation
clock, e.g. a command-line tool) and the run epoch (``""`` for none; a token a run draws once
so that datagrams of one run are never taken for another's). `b` holds the message's fields.
With a team key the tag covers the header, so tick and epoch cannot be altered: a receiver
rejects datagrams of another epoch and datagrams whose tick is stale (`murdoch.transport`).

Senders always write the same shape: ``{"h":`` first, no spaces, then ``,"b":``. No header
token can contain ``"``, ``\\``, ``[`` or ``]`` (kinds, sender ids, instances and subject names
are checked when encoding), so a receiver finds the end of the header at the first ``]``,
decodes just that slice, and decides from it alone whether any local subscription wants the
datagram; the body is decoded only for wanted traffic. A datagram that does not have this exact
shape but is valid JSON (other spacing or member order, escapes) is decoded whole and checked
the same way. Members other than h, b and mac, and repeated member names (at any depth), are
refused.

With a team key (see `murdoch.auth`) the object ends with a tag member, written exactly as
``,"mac":"<64 hex digits>"}``: HMAC-SHA256 of every byte before ``,"mac":`` (header and body,
everything a receiver acts on). Messages are frozen dataclasses with a class attribute
``KIND``; a `Codec` is built from the message classes a process understands (no global
registry), so any package can add its own kinds by passing its classes in. A class may set
``REPLY = True``: its messages answer a negotiation and may travel on a reply lane (see
`murdoch.multicast`). Field values are checked against the dataclass annotations on decode:
str, int, float, bool, None, ``X | None``, ``tuple[X, ...]``, fixed tuples and
``Mapping[str, Any]``. Lists decode to tuples, objects to read-only mappings.

Anything that does not fit raises `WireError` with a short ``reason`` used as a counter name
(``malformed``, ``bad_version``, ``unknown_kind``, ``bad_fields``, ``too_large``).
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import typing
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple, Protocol

from murdoch.subjects import SubjectError, SubjectSet, subject_set
from murdoch.wire_values import (
    COMPACT_PIECES,
    Converter,
    FlatBuilder,
    FlatReader,
    WireError,
    compile_converter,
    flat_builder,
    flat_reader,
    is_flat,
    json_string,
    reject_constant,
    thaw,
    unique_members,
)

WIRE_VERSION = 3
MAX_TICK = (1 << 53) - 1
MAX_DATAGRAM_BYTES = 1400
"""Hard limit; typical auction messages are 120-380 bytes (73 more when signed)."""
KIND_PATTERN = re.compile(r"^[a-z0-9][a-z0-9._-]{0,31}$")
TOKEN_PATTERN = re.compile(r'^[!#-Z^-~]{1,80}$')
"""Sender ids and instance nonces: 1-80 printable ASCII characters other than space,
double quote, backslash and square brackets."""
MAX_SEQ = (1 << 63) - 1
HEADER_START = b'{"h":['
"""How every datagram a sender writes begins."""
BODY_KEY = b',"b":'
MAC_KEY = b',"mac":"'
MAC_HEX_DIGITS = 64
MAC_SUFFIX_BYTES = len(MAC_KEY) + MAC_HEX_DIGITS + 2
"""Length of ``,"mac":"<hex>"}`` at the end of a signed datagram."""
_HEADER_SCAN_BYTES = 400
_HEX = frozenset(b"0123456789abcdef")
_TOP_MEMBERS = frozenset({"h", "b", "mac"})
_PLAIN_HEADER = re.compile(
    rb'\{"h":\[3,"(([a-z0-9][a-z0-9._-]{0,31})","([!#-Z^-~]{1,80})","([!#-Z^-~]{0,80}))",'
    rb'(0|[1-9][0-9]{0,18}),"([a-z0-9._:/,-]*)",(-1|0|[1-9][0-9]{0,15}),"([!#-Z^-~]{0,80})"\],'
    rb'"b":'
)
"""How every sender begins a datagram (version 3): the header tokens it may hold, unescaped."""
_plain_header_match = _PLAIN_HEADER.match
_BODY_ENDS = b"},"


def check_token(value: str, what: str) -> str:
    """Return `value` if it can stand in a header (sender id, instance), else ValueError."""
    if not isinstance(value, str) or not TOKEN_PATTERN.match(value):
        raise ValueError(f"{what} must be 1-80 printable ASCII characters other than space, "
                         f"quote, backslash and brackets, got {value!r}")
    return value


def signed_length(data: bytes) -> int:
    """How many leading bytes the tag of a signed datagram covers; -1 if `data` does not end
    with a tag member ``,"mac":"<64 lowercase hex>"}``."""
    at = len(data) - MAC_SUFFIX_BYTES
    if at < 0 or data[-2:] != b'"}' or data[at : at + len(MAC_KEY)] != MAC_KEY:
        return -1
    if not _HEX.issuperset(data[at + len(MAC_KEY) : -2]):
        return -1
    return at


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
    instance: str = ""
    tick: int = -1
    """The sender's simulation tick when it sent the message (-1: none)."""

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
    tick: int = -1
    epoch: str = ""


class Header(NamedTuple):
    """The header of a datagram, and where its body is.

    For a datagram of the standard shape the body is still undecoded bytes
    ``data[body_at:body_end]`` and `body` is None; for any other shape the whole datagram was
    decoded already and `body` holds the fields."""

    kind: str
    sender: str
    instance: str
    seq: int
    subjects: SubjectSet
    body_at: int
    body_end: int
    body: Mapping[str, Any] | None = None
    tick: int = -1
    epoch: str = ""


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
        self._replies: set[str] = set()
        self._subject_cache: dict[str, SubjectSet] = {}
        self._subject_text: dict[SubjectSet, bytes] = {}
        self._tokens: set[str] = set()
        self._checked_kinds: set[str] = set()
        self._builders: dict[str, Callable[[Mapping[str, Any]], Any]] = {}
        self._flat: dict[str, FlatReader] = {}
        """Kinds whose fields are all scalars: their bodies are read without the JSON
        decoder when they have the compact form senders write."""
        self._flat_builders: dict[str, FlatBuilder] = {}
        self._flat_keys: dict[str, tuple[str, ...]] = {}
        self._plain_idents: dict[bytes, tuple[str, str, str]] = {}
        self._plain_epochs: dict[bytes, str] = {}
        """Kind, sender and instance of headers read by `_PLAIN_HEADER`, as text."""
        self._plain_subjects: dict[bytes, SubjectSet] = {}
        self._decoder = json.JSONDecoder(
            parse_constant=reject_constant, object_pairs_hook=unique_members
        )
        self._encoder = json.JSONEncoder(separators=(",", ":"), allow_nan=False)
        for cls in message_types:
            if not dataclasses.is_dataclass(cls):
                raise TypeError(f"{cls.__name__} is not a dataclass")
            kind = getattr(cls, "KIND", None)
            if not isinstance(kind, str) or not KIND_PATTERN.match(kind):
                raise TypeError(
                    f"{cls.__name__} has no KIND of 1-32 characters of a-z 0-9 . _ -"
                )
            if kind in self._types and self._types[kind] is not cls:
                raise TypeError(f"two message classes share the kind {kind!r}")
            hints = typing.get_type_hints(cls)
            self._types[kind] = cls
            self._checked_kinds.add(kind)
            if getattr(cls, "REPLY", False) is True:
                self._replies.add(kind)
            names = [f.name for f in dataclasses.fields(cls)]
            self._converters[kind] = {n: compile_converter(hints[n], n) for n in names}
            self._field_names[kind] = frozenset(names)
            self._field_order[kind] = tuple(names)
            self._builders[kind] = self._builder(cls, kind)
            if all(f.init for f in dataclasses.fields(cls)):
                self._flat_keys[kind] = tuple(f'"{n}":' for n in names)
                if all(is_flat(hints[n]) for n in names):
                    self._flat[kind] = flat_reader(self._field_order[kind])
                if all(is_flat(hints[n]) or hints[n] in COMPACT_PIECES for n in names):
                    self._flat_builders[kind] = flat_builder(cls, kind, self._converters[kind])

    @property
    def kinds(self) -> frozenset[str]:
        return frozenset(self._types)

    def knows(self, kind: str) -> bool:
        return kind in self._types

    def is_reply(self, kind: str) -> bool:
        """Whether messages of `kind` answer a negotiation (class attribute REPLY = True)."""
        return kind in self._replies

    def extended(self, message_types: Iterable[type]) -> Codec:
        """A codec that also knows `message_types`."""
        return Codec([*self._types.values(), *message_types], self.max_datagram_bytes)

    def body_of(self, message: Any) -> dict[str, Any]:
        kind = getattr(message, "KIND", None)
        if not isinstance(kind, str) or not isinstance(message, self._types.get(kind, ())):
            raise WireError("unknown_kind", f"{type(message).__name__} is not in this codec")
        return {name: thaw(getattr(message, name)) for name in self._field_order[kind]}

    # -- encoding
    def encode_frame(
        self, sender: str, seq: int, subjects: SubjectSet, message: Any, instance: str = "",
        tick: int = -1, epoch: str = "",
    ) -> bytes:
        """The unauthenticated datagram bytes of one message (the standard shape)."""
        encoded = self._flat_body(message)
        if encoded is None:
            body = self.body_of(message)
            try:
                encoded = self._encoder.encode(body).encode("utf-8")
            except (TypeError, ValueError) as exc:
                raise WireError("bad_fields", f"{message.KIND}: {exc}") from None
        tokens = self._tokens
        if sender not in tokens or (instance and instance not in tokens):
            check_token(sender, "sender id")
            if instance:
                check_token(instance, "instance")
            if len(tokens) >= 4096:
                tokens.clear()
            tokens.update((sender, instance) if instance else (sender,))
        if type(seq) is not int or not 0 <= seq <= MAX_SEQ:
            raise ValueError(f"sequence must be an int in [0, 2**63), got {seq!r}")
        if type(tick) is not int or not -1 <= tick <= MAX_TICK:
            raise ValueError(f"tick must be an int in [-1, 2**53), got {tick!r}")
        if epoch and epoch not in tokens:
            check_token(epoch, "epoch")
            tokens.add(epoch)
        subject_text = self._subject_text.get(subjects)
        if subject_text is None:
            # subject names are checked by subject_set(): a-z 0-9 . _ : / - only
            subject_text = ",".join(sorted(subject_set(subjects))).encode("ascii")
            if len(self._subject_text) >= 4096:
                self._subject_text.clear()
            self._subject_text[subjects] = subject_text
        data = b'{"h":[%d,"%s","%s","%s",%d,"%s",%d,"%s"],"b":%s}' % (
            WIRE_VERSION,
            message.KIND.encode("ascii"),
            sender.encode("ascii"),
            instance.encode("ascii"),
            seq,
            subject_text,
            tick,
            epoch.encode("ascii"),
            encoded,
        )
        if len(data) > self.max_datagram_bytes:
            raise WireError(
                "too_large", f"{message.KIND} is {len(data)} bytes > {self.max_datagram_bytes}"
            )
        return data

    def _flat_body(self, message: Any) -> bytes | None:
        """The body of a message whose fields are scalars, lists of strings or empty objects,
        written directly (the same bytes the JSON encoder writes); None for other messages
        (the encoder writes them)."""
        kind = getattr(message, "KIND", None)
        if type(kind) is not str:
            return None
        keys = self._flat_keys.get(kind)
        if keys is None or type(message) is not self._types[kind]:
            return None
        parts = []
        for key, name in zip(keys, self._field_order[kind], strict=True):
            value = getattr(message, name)
            kind_of = type(value)
            if kind_of is str:
                text = json_string(value)
            elif kind_of is float:
                if not math.isfinite(value):
                    raise WireError("bad_fields", f"{kind}: non-finite number {value!r}")
                text = float.__repr__(value)
            elif kind_of is int:
                text = int.__repr__(value)
            elif value is None:
                text = "null"
            elif value is True:
                text = "true"
            elif value is False:
                text = "false"
            elif kind_of is tuple and all(type(item) is str for item in value):
                text = "[" + ",".join([json_string(item) for item in value]) + "]"
            elif not value and isinstance(value, Mapping):
                text = "{}"
            else:
                return None  # something the encoder must judge
            parts.append(key + text)
        return ("{" + ",".join(parts) + "}").encode("ascii")

    # -- decoding
    def decode_message(self, data: bytes, header: Header) -> Any:
        """The message a datagram carries, its body checked against the message class
        (`decode_body` then `message_from`, with the same result or the same error).

        The bodies of scalar-only kinds in the compact form senders write are read with one
        pattern match instead of the JSON decoder."""
        build = self._flat_builders.get(header.kind)
        if build is not None and header.body is None:
            message = build(data, header.body_at, header.body_end)
            if message is not None:
                return message
        return self.message_from(header.kind, self.decode_body(data, header))

    def parse_header(self, data: bytes) -> Header:
        """The header of a datagram (signed or not), cheap enough to run on every datagram
        before filtering: for the standard shape only the header array is decoded.

        The kind is not checked against this codec here (listeners show unknown kinds)."""
        if len(data) > self.max_datagram_bytes:
            raise WireError("too_large", f"{len(data)} bytes")
        plain = _plain_header_match(data)
        if plain is not None:
            known = self._plain_header(data, plain)
            if known is not None:
                return known
        if data[:6] == HEADER_START:
            end = data.find(b"]", 6, _HEADER_SCAN_BYTES)
            if end > 0 and data[end + 1 : end + 6] == BODY_KEY:
                signed_end = signed_length(data)
                body_end = signed_end if signed_end >= 0 else len(data) - 1
                if data[body_end:body_end + 1] in (b"}", b",") and body_end > end + 6:
                    try:
                        fields = self._decoder.decode(data[5 : end + 1].decode("ascii"))
                    except (UnicodeDecodeError, ValueError):
                        fields = None
                    if type(fields) is list:
                        kind, sender, instance, seq, subjects, tick, epoch = (
                            self._header_fields(fields))
                        return Header(kind, sender, instance, seq, subjects, end + 6, body_end,
                                      None, tick, epoch)
        return self._parse_whole(data)

    def _plain_header(self, data: bytes, plain: re.Match[bytes]) -> Header | None:
        """The header of a datagram that begins the way senders write it (`_PLAIN_HEADER`:
        compact, no escapes, every token of the allowed characters), with the subject set
        and the kind looked up in caches; None when something needs the general path to
        judge it (an unchecked subject set, a sequence number out of range, no body)."""
        ident_b, seq_b, subjects_b, tick_b, epoch_b = plain.group(1, 5, 6, 7, 8)
        subjects = self._plain_subjects.get(subjects_b)
        if subjects is None:
            try:
                subjects = self._parse_subjects(subjects_b.decode("ascii"))
            except WireError:
                return None
            if len(self._plain_subjects) >= 4096:
                self._plain_subjects.clear()
            self._plain_subjects[subjects_b] = subjects
        ident = self._plain_idents.get(ident_b)
        if ident is None:
            kind_b, sender_b, instance_b = plain.group(2, 3, 4)
            ident = (kind_b.decode("ascii"), sender_b.decode("ascii"), instance_b.decode("ascii"))
            if len(self._plain_idents) >= 4096:
                self._plain_idents.clear()
            self._plain_idents[ident_b] = ident
        seq = int(seq_b)
        body_at = plain.end()
        body_end = len(data) - 1
        if data[-2:] == b'"}':  # perhaps a tag member: the body ends before it
            signed_end = signed_length(data)
            if signed_end >= 0:
                body_end = signed_end
        if seq > MAX_SEQ or body_end <= body_at or data[body_end] not in _BODY_ENDS:
            return None
        tick = int(tick_b)
        if tick > MAX_TICK:
            return None
        epoch = self._plain_epochs.get(epoch_b)
        if epoch is None:
            epoch = epoch_b.decode("ascii")
            if len(self._plain_epochs) >= 64:
                self._plain_epochs.clear()
            self._plain_epochs[epoch_b] = epoch
        return Header(ident[0], ident[1], ident[2], seq, subjects, body_at, body_end, None,
                      tick, epoch)

    def decode_body(self, data: bytes, header: Header) -> Mapping[str, Any]:
        """The body's fields as a plain dict (`message_from` checks them)."""
        if header.body is not None:
            return header.body
        read = self._flat.get(header.kind)
        if read is not None:
            values = read(data, header.body_at, header.body_end)
            if values is not None:
                return dict(zip(self._field_order[header.kind], values, strict=True))
        try:
            body = self._decoder.decode(data[header.body_at : header.body_end].decode("utf-8"))
        except (UnicodeDecodeError, ValueError):
            body = None
        if type(body) is dict:
            return body
        whole = self._parse_whole(data)  # not the standard shape after all: decode it whole
        if whole[:5] != header[:5] or whole[8:] != header[8:]:
            raise WireError("malformed", "header and datagram disagree")
        assert whole.body is not None
        return whole.body

    def parse_frame(self, data: bytes) -> Frame:
        """Decode the header and the body; the body's fields are checked by `message_of`."""
        header = self.parse_header(data)
        body = self.decode_body(data, header)
        return Frame(header.kind, header.sender, header.seq, header.subjects, body,
                     header.instance, header.tick, header.epoch)

    def _parse_whole(self, data: bytes) -> Header:
        try:
            obj = self._decoder.decode(data.decode("utf-8"))
        except (UnicodeDecodeError, ValueError) as exc:
            raise WireError("malformed", f"not JSON: {exc}"[:200]) from None
        if type(obj) is not dict:
            raise WireError("malformed", "not a JSON object")
        fields = obj.get("h")
        if fields is None:
            if "v" in obj:
                raise WireError("bad_version", f"version {obj['v']!r}"[:80])
            raise WireError("malformed", "no header")
        if type(fields) is not list:
            raise WireError("malformed", "header is not an array")
        kind, sender, instance, seq, subjects, tick, epoch = self._header_fields(fields)
        if not _TOP_MEMBERS.issuperset(obj):
            raise WireError("malformed", f"unexpected members {sorted(set(obj) - _TOP_MEMBERS)}")
        body = obj.get("b")
        if type(body) is not dict:
            raise WireError("malformed", "body is not a JSON object")
        if "mac" in obj and type(obj["mac"]) is not str:
            raise WireError("malformed", "tag is not a string")
        return Header(kind, sender, instance, seq, subjects, -1, -1, body, tick, epoch)

    def _header_fields(
        self, fields: list[Any]
    ) -> tuple[str, str, str, int, SubjectSet, int, str]:
        if not fields:
            raise WireError("malformed", "empty header")
        version = fields[0]
        if type(version) is not int:
            raise WireError("malformed", f"version {version!r}"[:80])
        if version != WIRE_VERSION:
            raise WireError("bad_version", f"version {version}")
        if len(fields) != 8:
            raise WireError("malformed", f"header has {len(fields)} fields, not 8")
        _, kind, sender, instance, seq, subjects, tick, epoch = fields
        if type(kind) is not str or kind not in self._checked_kinds:
            if type(kind) is not str or not KIND_PATTERN.match(kind):
                raise WireError("malformed", f"bad kind {kind!r}"[:80])
            if len(self._checked_kinds) < 4096:
                self._checked_kinds.add(kind)
        tokens = self._tokens
        if type(sender) is not str or sender not in tokens:
            self._token(sender)
        if type(instance) is not str:
            raise WireError("malformed", f"bad instance {instance!r}"[:80])
        if instance and instance not in tokens:
            self._token(instance)
        if type(seq) is not int or not 0 <= seq <= MAX_SEQ:
            raise WireError("malformed", f"bad sequence {seq!r}"[:80])
        if type(tick) is not int or not -1 <= tick <= MAX_TICK:
            raise WireError("malformed", f"bad tick {tick!r}"[:80])
        if type(epoch) is not str:
            raise WireError("malformed", f"bad epoch {epoch!r}"[:80])
        if epoch and epoch not in tokens:
            self._token(epoch)
        subject_fs = self._subject_cache.get(subjects) if type(subjects) is str else None
        if subject_fs is None:
            subject_fs = self._parse_subjects(subjects)
        return kind, sender, instance, seq, subject_fs, tick, epoch

    def _token(self, value: Any) -> None:
        if type(value) is not str or not TOKEN_PATTERN.match(value):
            raise WireError("malformed", f"bad sender or instance {value!r}"[:100])
        if len(self._tokens) >= 4096:
            self._tokens.clear()
        self._tokens.add(value)

    def _parse_subjects(self, raw: Any) -> SubjectSet:
        if type(raw) is not str:
            raise WireError("malformed", f"subjects {raw!r} are not a string"[:100])
        if raw == "":
            result: SubjectSet = frozenset()
        else:
            try:
                result = subject_set(raw.split(","))
            except SubjectError as exc:
                raise WireError("malformed", f"bad subjects: {exc}"[:200]) from None
        if len(self._subject_cache) >= 4096:
            self._subject_cache.clear()
        self._subject_cache[raw] = result
        return result

    def message_of(self, frame: Frame) -> Any:
        return self.message_from(frame.kind, frame.body)

    def message_from(self, kind: str, body: Mapping[str, Any]) -> Any:
        """The message of `kind` whose fields are `body` (checked against the annotations)."""
        build = self._builders.get(kind)
        if build is None:
            raise WireError("unknown_kind", f"kind {kind!r}")
        return build(body)

    def _builder(self, cls: type, kind: str) -> Callable[[Mapping[str, Any]], Any]:
        converters = self._converters[kind]
        names = self._field_names[kind]
        pairs = tuple(converters.items())
        count = len(pairs)
        positional = all(f.init for f in dataclasses.fields(cls))

        def build(body: Mapping[str, Any]) -> Any:
            if len(body) != count or body.keys() != names:
                raise WireError("bad_fields", f"{kind} fields {sorted(body)} != {sorted(names)}")
            try:
                if positional:
                    return cls(*[convert(body[name]) for name, convert in pairs])
                return cls(**{name: convert(body[name]) for name, convert in pairs})
            except (TypeError, ValueError, OverflowError) as exc:
                if isinstance(exc, WireError):
                    raise
                raise WireError("bad_fields", f"{kind}: {exc}") from None

        return build


