"""The payloads of the team clock, an opaque device of a lockstep experiment run.

In a lockstep run every participant declares, before it asks for the next data round, how
many MURDOCH datagrams it has sent in all (a `Declaration`, opaque CMD 2), and every round
carries the table of all participants' counts (opaque DATA 1) so that each participant knows
which datagrams must have arrived before it acts (`murdoch.tick_order`). Both payloads are
compact JSON::

    declaration  {"s":"p1/0","n":12}
    table        {"c":{"p1/0":12,"p2/0":9,"user/0":31}}

Sender keys are ``sender/instance`` tokens (printable ASCII without space, quote, backslash
or brackets, at most 161 characters); counts are integers in [0, 2**53). Anything else is
refused with `ValueError`.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass

MAX_COUNT = (1 << 53) - 1
MAX_PAYLOAD_BYTES = 256 * 1024
_KEY = re.compile(r"^[!#-Z^-~]{1,80}/[!#-Z^-~]{0,80}$")


_KNOWN_KEYS: set[str] = set()
"""Keys already checked (a team's few dozen keys recur in every table); bounded."""
_KNOWN_KEYS_MAX = 4096


def check_key(key: object) -> str:
    if type(key) is str and key in _KNOWN_KEYS:
        return key
    if not isinstance(key, str) or not _KEY.match(key):
        raise ValueError(f"a sender key is 'sender/instance' in printable ASCII, got {key!r}"[:120])
    if len(_KNOWN_KEYS) < _KNOWN_KEYS_MAX:
        _KNOWN_KEYS.add(key)
    return key


def check_count(count: object) -> int:
    if type(count) is not int or not 0 <= count <= MAX_COUNT:
        raise ValueError(f"a datagram count is an integer in [0, 2**53), got {count!r}"[:120])
    return count


@dataclass(frozen=True)
class Declaration:
    """A participant's count of datagrams sent so far (sequence numbers 0 .. count - 1)."""

    key: str
    count: int

    def encode(self) -> bytes:
        return json.dumps({"s": check_key(self.key), "n": check_count(self.count)},
                          separators=(",", ":")).encode("ascii")

    @staticmethod
    def decode(data: bytes) -> Declaration:
        obj = _object(data)
        if set(obj) != {"s", "n"}:
            raise ValueError(f"a declaration has members s and n, got {sorted(obj)}"[:120])
        return Declaration(check_key(obj["s"]), check_count(obj["n"]))


def encode_table(counts: Mapping[str, int]) -> bytes:
    return json.dumps({"c": dict(sorted(counts.items()))},
                      separators=(",", ":")).encode("ascii")


def decode_table(data: bytes) -> dict[str, int]:
    obj = _object(data)
    table = obj.get("c")
    if set(obj) != {"c"} or not isinstance(table, dict):
        raise ValueError("a count table is {\"c\": {key: count}}")
    return {check_key(k): check_count(v) for k, v in table.items()}


def _object(data: bytes) -> dict[str, object]:
    if len(data) > MAX_PAYLOAD_BYTES:
        raise ValueError(f"team clock payload of {len(data)} bytes is too large")
    try:
        obj = json.loads(data.decode("ascii"), parse_constant=_no_constant)
    except (UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"team clock payload is not JSON: {exc}"[:120]) from None
    if not isinstance(obj, dict):
        raise ValueError("team clock payload is not a JSON object")
    return obj


def _no_constant(name: str) -> object:
    raise ValueError(f"{name} is not a count")
