"""`McapSink`: writes a recording in a process of its own, so whoever records never waits on
JSON encoding, compression or the disk, and never holds the interpreter lock for them.

`put(topic, t_s, message)` hands over a message (any thread; a dict, or a callable that
returns one, built in the writer process: it must pickle, so a module-level function or a
`functools.partial` of one). `put_group(t_s, build)` hands over the messages of one moment
at once: `build` (pickled likewise) returns them in the writer process as (topic, t_s,
message) items, so that what crosses the pipe is one compact sample, not a message each.
The writer process encodes each message as JSON, registers the topic's
channel and schema on first use (`channels.schema_of`) and appends it to the MCAP file:
zstd-compressed chunks of `chunk_size` bytes, each written as soon as it is full, and the file
flushed at least every `flush_period_s` of wall time. A crash of the recording process - or of
the writer - therefore leaves a file that `player_server.record.reader` reads up to its last
whole chunk; when the recording process dies, the writer finishes the file with what it got.
`close()` waits for what is left, the last chunk and the summary (indexes and message counts).

Messages travel over a pipe of `pipe_bytes`; when the writer falls behind, `put` waits, so
memory stays bounded if the disk (or the writer's CPU) falls behind. The writer process runs
at `nice` (lower priority than the run it records, by default), so it uses the time its CPUs
would otherwise leave idle.

`observer` (optional, it must pickle) travels to the writer process, sees every message
written there (`observer.written(topic, t_s, body)`, with the body as recorded) and comes back
with what it saw: after `close()`, `sink.observer` is that copy. A recorder derives from it what
it would otherwise have to read back.

`written` and `dropped` (messages that could not be pickled or encoded: counted, logged, not
written) are
known once `close()` has returned; `error` names a failure of the disk or of the writer
process (the recording stops, whoever records goes on).
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections.abc import Callable, Mapping
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any, BinaryIO, Protocol

from mcap.writer import CompressionType, Writer

from player_server.record import channels as ch

log = logging.getLogger(__name__)

Message = Mapping[str, Any] | Callable[[], Mapping[str, Any]]
Item = tuple[str, float, Message]
PIPE_BYTES = 1 << 20
"""The largest pipe an unprivileged Linux process may ask for (fs.pipe-max-size)."""
_F_SETPIPE_SZ = 1031
_STOP = "stop"
_GROUP = "*"
"""The topic of an item that stands for a group (`McapSink.put_group`): not a channel's."""


class WriteObserver(Protocol):
    def written(self, topic: str, t_s: float, body: Mapping[str, Any]) -> None: ...


class _Recording:
    """The file and its writer: encodes, registers channels, appends, flushes (one process
    owns it)."""

    def __init__(self, path: Path, chunk_size: int, metadata: Mapping[str, str] | None,
                 observer: WriteObserver | None) -> None:
        self.path = path
        self._file: BinaryIO = path.open("wb")
        self._writer = Writer(self._file, chunk_size=chunk_size,
                              compression=CompressionType.ZSTD)
        self._writer.start(profile=ch.PROFILE, library="murdoch")
        if metadata:
            self._writer.add_metadata("murdoch", dict(metadata))
        self._file.flush()  # a recording from its first moment: the header is on disk
        self.observer = observer
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self.written = 0
        self.dropped = 0
        self.error: str | None = None

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

    def write(self, items: list[Item]) -> None:
        if self.error is not None:
            return
        for topic, t_s, message in items:
            if topic == _GROUP:
                self._write_group(t_s, message)
                if self.error is not None:
                    return
                continue
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
                self._fail(f"recording stopped: {exc}")
                return
            else:
                if self.observer is not None:
                    self.observer.written(topic, t_s, body)

    def _write_group(self, t_s: float, build: Any) -> None:
        try:
            group = list(build())
        except (ValueError, TypeError) as exc:  # a group that cannot be built: count it
            self.dropped += 1
            if self.dropped <= 10:
                log.error("%s: messages of t=%g s not recorded: %s", self.path, t_s, exc)
            return
        self.write(group)

    def flush(self) -> None:
        if self.error is None:
            try:
                self._file.flush()
            except OSError as exc:
                self._fail(f"recording stopped: {exc}")

    def finish(self) -> None:
        try:
            if self.error is None:
                self._writer.finish()
        except OSError as exc:
            self._fail(f"recording not finished: {exc}")
        finally:
            self._file.close()

    def _fail(self, why: str) -> None:
        self.error = why
        log.error("%s: %s", self.path, why)


def _serve(items: Connection, results: Connection, path: str, chunk_size: int,
           flush_period_s: float, metadata: Mapping[str, str] | None,
           observer: WriteObserver | None, nice: int) -> None:
    """The writer process: write what comes until told to stop, until the recording
    process is gone or until terminated (as a daemon is when its parent exits without closing
    it), finish the file, send back (written, dropped, error, observer)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is for the run, which closes us
    terminated: list[bool] = []
    signal.signal(signal.SIGTERM, lambda *_: terminated.append(True))
    if nice:
        with contextlib.suppress(OSError):  # (a priority it may not take: it keeps its own)
            os.nice(nice)
    recording = _Recording(Path(path), chunk_size, metadata, observer)
    results.send("ready")
    next_flush = time.monotonic() + flush_period_s
    try:
        while True:
            if terminated:  # write what has arrived, then finish
                while items.poll(0):
                    try:
                        batch = items.recv()
                    except (EOFError, OSError):
                        break
                    if batch == _STOP:
                        break
                    recording.write(batch)
                break
            if items.poll(flush_period_s):
                try:
                    batch = items.recv()
                except (EOFError, OSError):
                    break  # the recording process is gone: keep what came
                if batch == _STOP:
                    break
                recording.write(batch)
            now = time.monotonic()
            if now >= next_flush:
                next_flush = now + flush_period_s
                recording.flush()
    finally:
        recording.finish()
        with contextlib.suppress(OSError):  # (nobody waits for it any more)
            results.send((recording.written, recording.dropped, recording.error,
                          recording.observer))


def _widen(conn: Connection, size: int) -> None:
    """Ask for a pipe of `size` bytes (Linux; elsewhere the default stays)."""
    with contextlib.suppress(OSError):
        fcntl.fcntl(conn.fileno(), _F_SETPIPE_SZ, size)


class McapSink:
    def __init__(self, path: Path, *, chunk_size: int = 1 << 20, flush_period_s: float = 1.0,
                 pipe_bytes: int = PIPE_BYTES, nice: int = 10, startup_s: float = 60.0,
                 metadata: Mapping[str, str] | None = None,
                 observer: WriteObserver | None = None) -> None:
        self.path = Path(path)
        self.path.open("wb").close()  # a path that cannot be written fails here, not later
        ctx = multiprocessing.get_context("spawn")
        items_in, self._items = ctx.Pipe(duplex=False)
        self._results, results_out = ctx.Pipe(duplex=False)
        _widen(self._items, pipe_bytes)
        self._proc = ctx.Process(
            target=_serve, name="mcap-writer", daemon=True,
            args=(items_in, results_out, str(self.path), chunk_size, flush_period_s,
                  dict(metadata) if metadata else None, observer, nice))
        self._proc.start()
        items_in.close()
        results_out.close()
        self.observer = observer
        self.written = 0
        self.dropped = 0
        self.error: str | None = None
        self._unsent = 0
        self._closed = False
        self._lock = threading.Lock()  # (one writer of the pipe at a time)
        self._await_ready(startup_s)

    def _await_ready(self, startup_s: float) -> None:
        """Wait until the writer has its file open and its signals set (so that from here on
        an ending recorder leaves a finished file). A writer still starting after
        ``startup_s`` (a loaded machine) is not given up: what is put waits in the pipe until
        it reads, and its late "ready" is passed over by `close`. Only a writer that ended
        stops the recording."""
        try:
            if self._results.poll(startup_s):
                if self._results.recv() == "ready":
                    return
            elif self._proc.is_alive():
                log.warning("%s: the writer process is still starting after %g s; recording "
                            "goes on", self.path, startup_s)
                return
        except (EOFError, OSError):
            pass
        self.error = (f"the writer process did not start within {startup_s:g} s "
                      f"(exit code {self._proc.exitcode})")
        log.error("%s: recording stopped: %s", self.path, self.error)

    @property
    def writer_pid(self) -> int | None:
        return self._proc.pid

    def put(self, topic: str, t_s: float, message: Message) -> None:
        self.put_many([(topic, t_s, message)])

    def put_group(self, t_s: float, build: Callable[[], list[Item]]) -> None:
        """Hand over the messages of one moment as `build`, which makes them (as (topic,
        t_s, message) items) in the writer process."""
        self.put_many([(_GROUP, t_s, build)])  # type: ignore[list-item]

    def put_many(self, items: list[Item]) -> None:
        """Hand over several messages at once (one write to the pipe; any thread)."""
        with self._lock:
            self._send(items)

    def _send(self, items: list[Item]) -> None:
        if self._closed:
            raise ValueError(f"recording {self.path} is closed")
        if self.error is not None:
            return
        try:
            self._items.send(items)
        except (pickle.PicklingError, AttributeError, TypeError) as exc:
            # a message that cannot travel (a lambda, an open file): count, go on
            self._unsent += len(items)
            if self._unsent <= 10:
                log.error("%s: %d message(s) not recorded: %s", self.path, len(items), exc)
        except (OSError, EOFError) as exc:
            self.error = f"the writer process is gone: {exc}"
            log.error("%s: recording stopped: %s", self.path, self.error)

    def close(self) -> None:
        """Wait for the writer to write what it has, the last chunk and the summary."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            with contextlib.suppress(OSError, EOFError):  # (a writer gone stops anyway)
                self._items.send(_STOP)
            self._items.close()
        result = None
        while result is None and (self._proc.is_alive() or self._results.poll(0)):
            try:
                if self._results.poll(0.5):
                    got = self._results.recv()
                    result = None if got == "ready" else got  # (a writer that started late)
            except (EOFError, OSError):
                break
        self._proc.join()
        self._results.close()
        self.dropped = self._unsent
        if result is None:
            self.error = self.error or (f"the writer process ended with exit code "
                                        f"{self._proc.exitcode} before finishing the file")
            log.error("%s: %s", self.path, self.error)
            return
        self.written, dropped, error, self.observer = result
        self.dropped = dropped + self._unsent
        self.error = self.error or error
