"""The consensus message: an agent's believed winning bids and its timestamps.

Only non-zero assignments travel, one ``(task, agent, bid)`` entry each (the CBGA paper's
sparse form); CBBA sends its (y, z) the same way (one entry per task that has a winner).
Agents and tasks are named by their index in the scenario, which every agent shares.
Bids and times are float64 so that equal bids stay equal on every agent.

CBGA adds, for group tasks only, each member's planned start time ``(task, agent, start)``, so
that group members can wait for each other when they plan.

`dense_encoded_size` is what the same information would cost as dense (tasks x places)
matrices, the form the paper's sparse entries replace; nothing is sent that way, the number
is reported beside the sparse bytes (`bytes_dense`).

Binary layout (big-endian): kind u8, sender u16, time f64, entry count u16, stamp count u16,
start count u16, then entries (task u16, agent u16, bid f64), stamps (f64 per agent, -inf =
never heard) and starts (task u16, agent u16, start f64).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

KIND_CBBA = 1
KIND_CBGA = 2

_HEADER = struct.Struct(">BHdHHH")
_ENTRY = struct.Struct(">HHd")
_STAMP = struct.Struct(">d")


class MessageError(ValueError):
    """Bytes that are not a consensus message."""


@dataclass(frozen=True)
class ConsensusMessage:
    kind: int
    sender: int
    time: float
    entries: tuple[tuple[int, int, float], ...]
    stamps: tuple[float, ...]
    starts: tuple[tuple[int, int, float], ...] = ()


def encoded_size(n_entries: int, n_stamps: int, n_starts: int = 0) -> int:
    return _HEADER.size + (n_entries + n_starts) * _ENTRY.size + n_stamps * _STAMP.size


_DENSE_CELL = struct.Struct(">Hd")  # a winner (agent index) and its bid


def dense_encoded_size(n_tasks: int, width: int, n_stamps: int, starts: bool) -> int:
    """The size of the same message in the dense form the CBGA paper compares its sparse
    entries with (its figure 3): every task's `width` (max L_j) winner places sent whether
    filled or not, as a winner index (u16) and a bid (f64) each, and with `starts` a
    start time (f64) per place too; the same header and stamps as `encoded_size`."""
    cell = _DENSE_CELL.size + (_STAMP.size if starts else 0)
    return _HEADER.size + n_tasks * width * cell + n_stamps * _STAMP.size


def encode(msg: ConsensusMessage) -> bytes:
    parts = [_HEADER.pack(msg.kind, msg.sender, msg.time, len(msg.entries), len(msg.stamps),
                          len(msg.starts))]
    parts.extend(_ENTRY.pack(j, m, b) for j, m, b in msg.entries)
    parts.append(struct.pack(f">{len(msg.stamps)}d", *msg.stamps))
    parts.extend(_ENTRY.pack(j, m, t) for j, m, t in msg.starts)
    return b"".join(parts)


def decode(data: bytes) -> ConsensusMessage:
    if len(data) < _HEADER.size:
        raise MessageError(f"consensus message too short: {len(data)} bytes")
    kind, sender, time, n_entries, n_stamps, n_starts = _HEADER.unpack_from(data, 0)
    if kind not in (KIND_CBBA, KIND_CBGA):
        raise MessageError(f"unknown consensus message kind {kind}")
    if len(data) != encoded_size(n_entries, n_stamps, n_starts):
        raise MessageError(
            f"consensus message length {len(data)} does not match its counts "
            f"({n_entries} entries, {n_stamps} stamps, {n_starts} starts)")
    off = _HEADER.size
    entries = []
    for _ in range(n_entries):
        entries.append(_ENTRY.unpack_from(data, off))
        off += _ENTRY.size
    stamps = struct.unpack_from(f">{n_stamps}d", data, off)
    off += n_stamps * _STAMP.size
    starts = []
    for _ in range(n_starts):
        starts.append(_ENTRY.unpack_from(data, off))
        off += _ENTRY.size
    return ConsensusMessage(kind, sender, time, tuple(entries), tuple(stamps), tuple(starts))
