"""Declarative XDR structs the way Player's generated packers encode them.

A message body is a frozen dataclass whose annotations name wire types, declared with
``@xdr_dataclass`` (a frozen, slotted dataclass run through ``xdr_struct``):
``common.Pose2d`` (three ``F64``) is the simplest, ``sensor_msgs.LaserData`` shows counted
arrays.

``xdr_struct`` compiles, once per class, an ``encode(obj) -> bytes`` and a
``decode(buf, offset) -> (obj, offset)`` function. Consecutive fixed-size members
(scalars and nested fixed structs) share one precompiled ``struct.Struct``.

Wire rules (big-endian throughout):

* ``U32``/``I32``: 4 bytes. ``U8``/``U16``/``I8``/``I16``/``BOOL``: C types of 8 or
  16 bits that occupy a whole 4-byte word (``U*`` zero-, ``I*`` sign-extended).
* ``F32``/``F64``: IEEE single/double. ``I64``: 8-byte hyper.
* ``Array(T)``: a C array with a sibling ``x_count`` member: the count word, the
  count again (XDR variable array), then the elements.
* ``Bytes``: the same for byte arrays: count, count, raw bytes, zero pad to 4.
* ``String``: counted bytes whose count includes the terminating NUL (empty string
  = count 0); decoding cuts at the first NUL.
"""

from __future__ import annotations

import dataclasses
import struct
import typing
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Annotated, Any, ClassVar, TypeVar, dataclass_transform

from player_server.frozen import frozen_constructor
from player_server.protocol.errors import DecodeError, EncodeError


@dataclass(frozen=True)
class Scalar:
    """A fixed-size wire scalar; ``code`` is its ``struct`` format character."""

    code: str
    name: str


@dataclass(frozen=True)
class Array:
    """A counted array of scalars or fixed structs (count written twice)."""

    elem: Any
    max_count: int | None = None


@dataclass(frozen=True)
class Bytes:
    """A counted byte array (count written twice, padded to 4)."""

    max_count: int | None = None


@dataclass(frozen=True)
class String:
    """A counted, NUL-terminated byte string (count includes the NUL)."""

    max_count: int | None = None


_U32 = Scalar("I", "u32")
_I32 = Scalar("i", "i32")
_F32 = Scalar("f", "f32")
_F64 = Scalar("d", "f64")
_I64 = Scalar("q", "i64")
WIRE_U32 = _U32
WIRE_I32 = _I32
WIRE_F32 = _F32
WIRE_F64 = _F64

U32 = Annotated[int, _U32]
I32 = Annotated[int, _I32]
U16 = Annotated[int, _U32]
I16 = Annotated[int, _I32]
U8 = Annotated[int, _U32]
I8 = Annotated[int, _I32]
BOOL = Annotated[int, _U32]
F32 = Annotated[float, _F32]
F64 = Annotated[float, _F64]
I64 = Annotated[int, _I64]

F32Array = Annotated[tuple[float, ...], Array(_F32)]
F64Array = Annotated[tuple[float, ...], Array(_F64)]
U32Array = Annotated[tuple[int, ...], Array(_U32)]
ByteArray = Annotated[bytes, Bytes()]
Text = Annotated[str, String()]

_COUNT = struct.Struct(">II")
_MAX_DEFAULT_COUNT = 8 * 1024 * 1024


@lru_cache(maxsize=512)
def _array_struct(code: str, count: int) -> struct.Struct:
    return struct.Struct(f">{count}{code}")


def _pad(n: int) -> int:
    return (-n) & 3


T = TypeVar("T")


class XdrStruct(typing.Protocol):
    """What ``xdr_struct`` adds to a dataclass."""

    XDR_FIXED_SIZE: ClassVar[int | None]

    @staticmethod
    def xdr_encode(obj: Any) -> bytes: ...

    @staticmethod
    def xdr_decode(buf: bytes | memoryview, offset: int) -> tuple[Any, int]: ...


def _field_specs(cls: type) -> list[tuple[str, Any]]:
    hints = typing.get_type_hints(cls, include_extras=True)
    specs: list[tuple[str, Any]] = []
    for f in dataclasses.fields(cls):
        hint = hints[f.name]
        if typing.get_origin(hint) is Annotated:
            meta = hint.__metadata__[0]
            specs.append((f.name, meta))
        elif isinstance(hint, type) and hasattr(hint, "xdr_encode"):
            specs.append((f.name, hint))
        else:
            raise TypeError(f"{cls.__name__}.{f.name}: no wire type in annotation {hint!r}")
    return specs


def _is_fixed(spec: Any) -> bool:
    if isinstance(spec, Scalar):
        return True
    return isinstance(spec, type) and getattr(spec, "XDR_FIXED_SIZE", None) is not None


def _flatten(spec: Any, expr: str) -> tuple[str, list[str]]:
    """Format codes and attribute expressions of a fixed member, nested structs inline."""
    if isinstance(spec, Scalar):
        return spec.code, [expr]
    codes = ""
    exprs: list[str] = []
    for name, sub in spec.XDR_SPECS:
        c, e = _flatten(sub, f"{expr}.{name}")
        codes += c
        exprs += e
    return codes, exprs


def _rebuild(spec: Any, values: str, start: int, ns: dict[str, Any]) -> tuple[str, int]:
    """Source expression rebuilding a fixed member from a tuple of unpacked values."""
    if isinstance(spec, Scalar):
        return f"{values}[{start}]", start + 1
    key = f"_C{len(ns)}"
    ns[key] = spec.xdr_make
    parts = []
    i = start
    for _name, sub in spec.XDR_SPECS:
        src, i = _rebuild(sub, values, i, ns)
        parts.append(src)
    return f"{key}({', '.join(parts)})", i


def _compile_variable(i: int, member: tuple[str, Any], enc: list[str], dec: list[str],
                      ns: dict[str, Any]) -> None:
    """Source lines encoding and decoding the variable-size member `i` (arrays, byte
    arrays, strings, nested structs of variable size)."""
    name, spec = member
    skey = f"_X{i}"
    ns[skey] = spec
    if isinstance(spec, Array) and isinstance(spec.elem, Scalar):
        # inlined: the sensor arrays are the bulk of every data round
        limit = spec.max_count if spec.max_count is not None else _MAX_DEFAULT_COUNT
        code = spec.elem.code
        enc.append(f"    parts.append(_enc_array({skey}, o.{name}))")
        dec.append("    n, n2 = _unpack_count(b, off)")
        dec.append(f"    if n != n2 or n > {limit}:")
        dec.append(f"        _read_counts({skey}, b, off)")
        dec.append(f"    st = _array_struct({code!r}, n)")
        dec.append(f"    f_{name} = st.unpack_from(b, off + 8)")
        dec.append("    off += 8 + st.size")
    elif isinstance(spec, Array):
        # arrays of structs: the elements' unwrapped codecs (errors surface through
        # this class's wrapper)
        limit = spec.max_count if spec.max_count is not None else _MAX_DEFAULT_COUNT
        ekey = f"_E{i}"
        ns[ekey] = spec.elem.xdr_decode_raw
        ns[f"_EE{i}"] = spec.elem.xdr_encode_raw
        enc.append(f"    n = len(o.{name})")
        enc.append(f"    if n > {limit}:")
        enc.append(f"        _check_count(n, {skey})")
        enc.append("    parts.append(_COUNT.pack(n, n))")
        enc.append(f"    parts.append(b''.join(map(_EE{i}, o.{name})))")
        dec.append("    n, n2 = _unpack_count(b, off)")
        dec.append(f"    if n != n2 or n > {limit}:")
        dec.append(f"        _read_counts({skey}, b, off)")
        dec.append("    off += 8")
        dec.append("    items = []")
        dec.append("    for _ in range(n):")
        dec.append(f"        item, off = {ekey}(b, off)")
        dec.append("        items.append(item)")
        dec.append(f"    f_{name} = tuple(items)")
    elif isinstance(spec, Bytes):
        enc.append(f"    parts.append(_enc_bytes({skey}, o.{name}))")
        dec.append(f"    f_{name}, off = _dec_bytes({skey}, b, off)")
    elif isinstance(spec, String):
        enc.append(f"    parts.append(_enc_string({skey}, o.{name}))")
        dec.append(f"    f_{name}, off = _dec_string({skey}, b, off)")
    else:  # a variable-size nested struct
        ns[f"_NE{i}"] = spec.xdr_encode_raw
        ns[f"_ND{i}"] = spec.xdr_decode_raw
        enc.append(f"    parts.append(_NE{i}(o.{name}))")
        dec.append(f"    f_{name}, off = _ND{i}(b, off)")


def _compile(cls: type, specs: list[tuple[str, Any]]) -> None:
    ns: dict[str, Any] = {
        "_COUNT": _COUNT,
        "_unpack_count": _COUNT.unpack_from,
        "_read_counts": _read_counts,
        "_check_count": _check_count,
        "_array_struct": _array_struct,
        "_pad": _pad,
        "_enc_array": _enc_array,
        "_dec_array": _dec_array,
        "_enc_bytes": _enc_bytes,
        "_dec_bytes": _dec_bytes,
        "_enc_string": _enc_string,
        "_dec_string": _dec_string,
        "_cls": cls,
        "_make": frozen_constructor(cls),
    }
    enc = ["def encode(o):", "    parts = []"]
    dec = ["def decode(b, off):"]
    names = [name for name, _ in specs]
    i = 0
    fixed_size = 0
    all_fixed = True
    while i < len(specs):
        if _is_fixed(specs[i][1]):
            j = i
            codes = ""
            exprs: list[str] = []
            while j < len(specs) and _is_fixed(specs[j][1]):
                c, e = _flatten(specs[j][1], f"o.{specs[j][0]}")
                codes += c
                exprs += e
                j += 1
            skey = f"_S{i}"
            st = struct.Struct(">" + codes)
            ns[skey] = st
            fixed_size += st.size
            enc.append(f"    parts.append({skey}.pack({', '.join(exprs)}))")
            dec.append(f"    v = {skey}.unpack_from(b, off)")
            dec.append(f"    off += {st.size}")
            pos = 0
            for k in range(i, j):
                src, pos = _rebuild(specs[k][1], "v", pos, ns)
                dec.append(f"    f_{specs[k][0]} = {src}")
            i = j
            continue
        all_fixed = False
        _compile_variable(i, specs[i], enc, dec, ns)
        i += 1
    enc.append("    return b''.join(parts)")
    dec.append(f"    return _make({', '.join('f_' + n for n in names)}), off")
    exec("\n".join(enc), ns)
    exec("\n".join(dec), ns)
    raw_encode: Callable[[Any], bytes] = ns["encode"]
    raw_decode: Callable[[Any, int], tuple[Any, int]] = ns["decode"]

    def xdr_encode(obj: Any) -> bytes:
        try:
            return raw_encode(obj)
        except (struct.error, TypeError, ValueError, OverflowError) as exc:
            raise EncodeError(f"{cls.__name__}: cannot encode {obj!r}: {exc}") from exc

    def xdr_decode(buf: bytes | memoryview, offset: int = 0) -> tuple[Any, int]:
        try:
            return raw_decode(buf, offset)
        except (struct.error, UnicodeDecodeError, TypeError, ValueError) as exc:
            raise DecodeError(f"{cls.__name__}: {exc}") from exc

    cls.XDR_SPECS = tuple(specs)  # type: ignore[attr-defined]
    cls.XDR_FIXED_SIZE = fixed_size if all_fixed else None  # type: ignore[attr-defined]
    cls.xdr_encode = staticmethod(xdr_encode)  # type: ignore[attr-defined]
    cls.xdr_decode = staticmethod(xdr_decode)  # type: ignore[attr-defined]
    cls.xdr_make = staticmethod(ns["_make"])  # type: ignore[attr-defined]
    #: the same without the error translation (for use inside other compiled codecs)
    cls.xdr_encode_raw = staticmethod(raw_encode)  # type: ignore[attr-defined]
    cls.xdr_decode_raw = staticmethod(raw_decode)  # type: ignore[attr-defined]


COUNT_WORDS = _COUNT
"""The two count words in front of every counted array, byte array and string."""


def wire_layout(cls: type, upto: str | None = None) -> struct.Struct:
    """The declared wire layout of `cls` as one big-endian ``struct.Struct``.

    Every member must be fixed-size, or, with `upto`, every member before the counted array
    `upto`, whose two count words end the layout (the head a reader unpacks before the
    elements). Readers that take bodies apart by hand take their layouts from here, so they
    and the declarations cannot drift apart."""
    codes = ""
    for name, spec in _field_specs(cls):
        if name == upto:
            if not isinstance(spec, Array | Bytes | String):
                raise TypeError(f"{cls.__name__}.{name} is not a counted array")
            return struct.Struct(">" + codes + "II")
        if not _is_fixed(spec):
            raise TypeError(f"{cls.__name__}.{name} has no fixed size")
        codes += _flatten(spec, name)[0]
    if upto is not None:
        raise TypeError(f"{cls.__name__} has no member {upto!r}")
    return struct.Struct(">" + codes)


def xdr_struct(cls: type[T]) -> type[T]:
    """Class decorator: compile the wire codec of a frozen dataclass."""
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls.__name__} must be a dataclass")
    _compile(cls, _field_specs(cls))
    return cls


@dataclass_transform(frozen_default=True)
def xdr_dataclass(cls: type[T]) -> type[T]:
    """Class decorator declaring a wire struct: a frozen, slotted dataclass whose codec is
    compiled by `xdr_struct`. Every body and nested struct of the protocol is declared so."""
    return xdr_struct(dataclass(frozen=True, slots=True)(cls))


def _check_count(n: int, spec: Array | Bytes | String) -> None:
    limit = spec.max_count if spec.max_count is not None else _MAX_DEFAULT_COUNT
    if n > limit:
        raise ValueError(f"count {n} exceeds the limit {limit}")


def _enc_array(spec: Array, values: Any) -> bytes:
    n = len(values)
    _check_count(n, spec)
    elem = spec.elem
    if isinstance(elem, Scalar):
        return _COUNT.pack(n, n) + _array_struct(elem.code, n).pack(*values)
    return _COUNT.pack(n, n) + b"".join(elem.xdr_encode(v) for v in values)


def _read_counts(spec: Array | Bytes | String, b: Any, off: int) -> tuple[int, int]:
    n, n2 = _COUNT.unpack_from(b, off)
    if n != n2:
        raise ValueError(f"array counts differ ({n} then {n2})")
    _check_count(n, spec)
    return n, off + 8


def _dec_array(spec: Array, b: Any, off: int) -> tuple[tuple[Any, ...], int]:
    n, off = _read_counts(spec, b, off)
    elem = spec.elem
    if isinstance(elem, Scalar):
        st = _array_struct(elem.code, n)
        return st.unpack_from(b, off), off + st.size
    out = []
    for _ in range(n):
        v, off = elem.xdr_decode(b, off)
        out.append(v)
    return tuple(out), off


def _enc_bytes(spec: Bytes, value: bytes) -> bytes:
    n = len(value)
    _check_count(n, spec)
    return _COUNT.pack(n, n) + bytes(value) + b"\0" * _pad(n)


def _dec_bytes(spec: Bytes, b: Any, off: int) -> tuple[bytes, int]:
    n, off = _read_counts(spec, b, off)
    end = off + n
    if end + _pad(n) > len(b):
        raise ValueError(f"byte array of {n} runs past the end of the body")
    return bytes(b[off:end]), end + _pad(n)


def _enc_string(spec: String, value: str) -> bytes:
    raw = value.encode("utf-8")
    if b"\0" in raw:
        raise ValueError("string contains a NUL byte")
    if raw:
        raw += b"\0"
    n = len(raw)
    _check_count(n, spec)
    return _COUNT.pack(n, n) + raw + b"\0" * _pad(n)


def _dec_string(spec: String, b: Any, off: int) -> tuple[str, int]:
    n, off = _read_counts(spec, b, off)
    end = off + n
    if end + _pad(n) > len(b):
        raise ValueError(f"string of {n} bytes runs past the end of the body")
    raw = bytes(b[off:end])
    cut = raw.find(b"\0")
    if cut >= 0:
        raw = raw[:cut]
    return raw.decode("utf-8", errors="replace"), end + _pad(n)


def encode_body(body: Any) -> bytes:
    """Encode a body dataclass (``None`` = empty body)."""
    if body is None:
        return b""
    return typing.cast(bytes, type(body).xdr_encode(body))


def decode_body(cls: Any, buf: bytes | memoryview) -> Any:
    """Decode a whole body of class ``cls``; trailing bytes are an error."""
    obj, end = cls.xdr_decode(buf, 0)
    if end != len(buf):
        raise DecodeError(f"{cls.__name__}: {len(buf) - end} unexpected trailing bytes")
    return obj
