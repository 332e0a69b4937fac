"""Reading a run recording back, whole or cut short by a crash.

`iter_messages(path)` yields `Record`s: in log-time order from a finished file (through its
index), in file order from one without a summary (a crashed run), up to the last record that
is whole; `RecordingInfo.truncated` then says so. `read_info(path)` counts messages per
channel and the time span without decoding any message.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, make_reader

log = logging.getLogger(__name__)


class RecordingError(ValueError):
    """Not a readable recording (with the file and what was wrong)."""


@dataclass(frozen=True, slots=True)
class Record:
    topic: str
    schema: str
    log_time_ns: int
    data: bytes

    @property
    def t_s(self) -> float:
        return self.log_time_ns / 1e9

    def json(self) -> Any:
        return json.loads(self.data)


@dataclass
class ChannelInfo:
    topic: str
    schema: str
    encoding: str
    messages: int = 0
    first_ns: int | None = None
    last_ns: int | None = None


@dataclass
class RecordingInfo:
    path: Path
    bytes: int
    profile: str = ""
    complete: bool = True
    truncated: bool = False
    chunks: int = 0
    channels: dict[str, ChannelInfo] = field(default_factory=dict)
    start_ns: int = 0
    end_ns: int = 0

    @property
    def messages(self) -> int:
        return sum(c.messages for c in self.channels.values())

    @property
    def duration_s(self) -> float:
        return max(0, self.end_ns - self.start_ns) / 1e9


def resolve(path: Path) -> Path:
    """RUN_DIR or RUN_DIR/run.mcap -> the .mcap file; RecordingError when there is none."""
    p = Path(path)
    if p.is_dir():
        p = p / "run.mcap"
    if not p.is_file():
        raise RecordingError(f"{path}: no recording found (expected a run directory holding "
                             f"run.mcap, or an .mcap file)")
    return p


def _check_magic(path: Path) -> None:
    with path.open("rb") as f:
        head = f.read(8)
    if head != b"\x89MCAP0\r\n":
        raise RecordingError(f"{path}: not an MCAP file (it starts with {head[:8]!r})")


def iter_messages(path: Path, topics: Iterable[str] | None = None,
                  info: RecordingInfo | None = None) -> Iterator[Record]:
    """Messages of the recording; on a file cut short, those before the cut (and
    `info.truncated` is set)."""
    path = resolve(path)
    _check_magic(path)
    wanted = list(topics) if topics is not None else None
    with path.open("rb") as f:
        try:
            summary = make_reader(f).get_summary()
        except McapError:
            summary = None
        f.seek(0)
        if summary is not None and summary.chunk_indexes:
            reader = make_reader(f)
            for schema, channel, msg in reader.iter_messages(topics=wanted):
                yield Record(channel.topic, schema.name if schema else "", msg.log_time,
                             msg.data)
            return
        if info is not None:
            info.complete = False
        try:
            for schema, channel, msg in NonSeekingReader(f).iter_messages(
                    topics=wanted, log_time_order=False):
                yield Record(channel.topic, schema.name if schema else "", msg.log_time,
                             msg.data)
        except Exception as exc:  # the cut record may fail to decode in any way
            if info is not None:
                info.truncated = True
            log.info("%s: read up to where the file was cut (%s)", path, exc or "end")


def read_info(path: Path) -> RecordingInfo:
    """Channels, message counts and time span of a recording."""
    path = resolve(path)
    _check_magic(path)
    info = RecordingInfo(path, path.stat().st_size)
    with path.open("rb") as f:
        try:
            reader = make_reader(f)
            info.profile = reader.get_header().profile
        except McapError as exc:
            raise RecordingError(f"{path}: unreadable MCAP header: {exc}") from exc
        try:
            summary = reader.get_summary()
        except McapError:  # no footer: the file was cut short
            summary = None
    if summary is not None and summary.statistics is not None:
        stats = summary.statistics
        for cid, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            info.channels[channel.topic] = ChannelInfo(
                channel.topic, schema.name if schema else "", channel.message_encoding,
                stats.channel_message_counts.get(cid, 0))
        info.chunks = stats.chunk_count
        info.start_ns, info.end_ns = stats.message_start_time, stats.message_end_time
        return info
    first = last = None
    for rec in iter_messages(path, info=info):
        c = info.channels.get(rec.topic)
        if c is None:
            c = info.channels[rec.topic] = ChannelInfo(rec.topic, rec.schema, "json")
        c.messages += 1
        first = rec.log_time_ns if first is None else min(first, rec.log_time_ns)
        last = rec.log_time_ns if last is None else max(last, rec.log_time_ns)
    info.complete = False
    info.start_ns, info.end_ns = first or 0, last or 0
    return info
