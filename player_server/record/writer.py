"""`McapSink`: writes a recording on a thread of its own, so whoever records never waits on
JSON encoding, compression or the disk.

`put(topic, t_s, message)` hands over a message (any thread; a dict, or a callable that
returns one, built on the writer thread). The thread encodes it as JSON, registers the
topic's channel and schema on first use (`channels.schema_of`) and appends it to the MCAP
file: zstd-compressed chunks of `chunk_size` bytes, each written as soon as it is full, and the
file flushed at least every `flush_period_s` of wall time. A crash therefore leaves a file that
`player_server.record.reader` reads up to its last whole chunk. `close()` writes what is left
and the summary (indexes and message counts). Up to `max_pending` messages wait; beyond that
`put` blocks, so memory stays bounded if the disk falls behind. `on_written(topic, t_s, body)`
is called on the writer thread after each message is in the file, with the body written: the
recorder derives from it what it would otherwise have to read back.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, BinaryIO

from mcap.writer import CompressionType, Writer

from player_server.record import channels as ch

log = logging.getLogger(__name__)

Message = Mapping[str, Any] | Callable[[], Mapping[str, Any]]
_STOP = object()


class McapSink:
    def __init__(self, path: Path, *, clock: Callable[[], float], chunk_size: int = 1 << 20,
                 flush_period_s: float = 1.0, max_pending: int = 200_000,
                 metadata: Mapping[str, str] | None = None,
                 on_written: Callable[[str, float, Any], None] | None = None) -> None:
        self.path = Path(path)
        self._clock = clock
        self._file: BinaryIO = self.path.open("wb")
        self._writer = Writer(self._file, chunk_size=chunk_size,
                              compression=CompressionType.ZSTD)
        self._writer.start(profile=ch.PROFILE, library="murdoch")
        if metadata:
            self._writer.add_metadata("murdoch", dict(metadata))
        self._flush_period = flush_period_s
        self._on_written = on_written
        self._queue: queue.Queue[Any] = queue.Queue(max_pending)
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self.written = 0
        self.dropped = 0
        self.error: BaseException | None = None
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="mcap-writer", daemon=True)
        self._thread.start()

    def put(self, topic: str, t_s: float, message: Message) -> None:
        self.put_many([(topic, t_s, message)])

    def put_many(self, items: list[tuple[str, float, Message]]) -> None:
        """Hand over several messages at once (one queue operation)."""
        if self._closed:
            raise ValueError(f"recording {self.path} is closed")
        self._queue.put(items)

    def _channel(self, topic: str) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            schema = ch.schema_of(topic)
            sid = self._schemas.get(schema)
            if sid is None:
                sid = self._schemas[schema] = self._writer.register_schema(
                    schema, ch.SCHEMA_ENCODING, ch.schema_bytes(schema))
            cid = self._channels[topic] = self._writer.register_channel(
                topic, ch.ENCODING, sid)
        return cid

    def _run(self) -> None:
        next_flush = self._clock() + self._flush_period
        while True:
            try:
                item = self._queue.get(timeout=self._flush_period)
            except queue.Empty:
                item = None
            if item is _STOP:
                return
            if item is not None and self.error is None:
                self._write(item)
            now = self._clock()
            if now >= next_flush and self.error is None:
                next_flush = now + self._flush_period
                try:
                    self._file.flush()
                except OSError as exc:
                    self.error = exc
                    log.error("%s: recording stopped: %s", self.path, exc)

    def _write(self, items: list[tuple[str, float, Message]]) -> None:
        for topic, t_s, message in items:
            try:
                body = message() if callable(message) else message
                ns = ch.nanoseconds(t_s)
                self._writer.add_message(self._channel(topic), log_time=ns,
                                         data=ch.encode(body), publish_time=ns)
                self.written += 1
            except (ValueError, TypeError) as exc:  # one bad message: count, go on
                self.dropped += 1
                if self.dropped <= 10:
                    log.error("%s: message on %s not recorded: %s", self.path, topic, exc)
            except OSError as exc:  # the disk: stop recording, keep the run going
                self.error = exc
                log.error("%s: recording stopped: %s", self.path, exc)
                return
            else:
                if self._on_written is not None:
                    self._on_written(topic, t_s, body)

    def close(self) -> None:
        """Write what waits, the last chunk and the summary; close the file."""
        if self._closed:
            return
        self._closed = True
        self._queue.put(_STOP)
        self._thread.join()
        try:
            if self.error is None:
                self._writer.finish()
        except OSError as exc:
            self.error = exc
            log.error("%s: recording not finished: %s", self.path, exc)
        finally:
            self._file.close()
