"""The transport interface and the receive pipeline every transport shares.

The interface is deliberately small::

    transport.publish(subjects, message) -> int          # datagram size in bytes
    sub = transport.subscribe(subjects, callback=None)   # a Subscription handle
    transport.poll(timeout_s=0.0) -> int                 # receive and dispatch; count delivered
    transport.counters                                   # Counters: per kind, sent/received
    transport.close()

`subjects` is any iterable of subject names (or a comma-separated string), or None for a
monitor that hears every message whatever its subjects (listeners, loggers); `message` is a
frozen dataclass instance whose class is in the transport's `Codec`. A `Subscription` is a
context manager; it receives each message whose subject set is a subset of its own subjects,
either through `callback(envelope)` (called from inside `poll`) or, without a callback, in a
bounded queue read with `drain()`. `update(subjects)` changes what it listens to in place;
`close()` stops it. Every transport delivers a publisher's own messages to its own matching
subscriptions too (multicast loops them back), so all transports behave alike.

`EndpointCore` holds what is common: sequence numbering, signing, the receive pipeline and
the counters. Transports only move bytes. The pipeline decodes only the small header array
first and decides from it, before decoding the body (or authenticating), whether a local
subscription wants the datagram: size check, tag present (when keyed), header, subject match
(cached per subject set), then, only for datagrams someone listens to, tag check, replay
check, body decode and dispatch.

A subscription also says whether its owner must be woken for *replies* (messages whose class
sets ``REPLY = True``, e.g. bids, awards and reports, needed at once only by the party waiting
for them): `wake_on_replies`, True by default. It is a permission, not a filter: a transport
that carries replies separately (multicast with its reply lane on) waits on them only while
some subscription wants that and otherwise reads them whenever it polls anyway, before the
other traffic; a transport with one channel (the default multicast, the memory bus) wakes for
everything. No datagram is skipped either way. `wake_on_traffic = False` goes further: the
owner polls on its own timer and nothing that arrives needs to wake it (a bidder resting
between its bid and its look at the other bids); while every subscription says so (and there
is no frame tap) a waiting poll only waits out its timeout, then reads what is queued.
"""

from __future__ import annotations

import logging
import os
import threading
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, Protocol

from murdoch.auth import ReplayWindow, TeamKey, is_signed
from murdoch.ratelog import RateLimitedLog
from murdoch.subjects import SubjectIndex, SubjectSet, subject_set
from murdoch.tick_order import LostDatagrams, TickInbox, sender_key
from murdoch.wire import Codec, Envelope, Frame, WireError, check_token

log = logging.getLogger(__name__)

Clock = Callable[[], float]
Callback = Callable[[Envelope], None]


@dataclass
class KindCount:
    sent_msgs: int = 0
    sent_bytes: int = 0
    recv_msgs: int = 0
    recv_bytes: int = 0


@dataclass
class Counters:
    """Messages and bytes per kind, plus dropped datagrams per reason."""

    kinds: dict[str, KindCount] = field(default_factory=dict)
    dropped: dict[str, int] = field(default_factory=dict)

    def count_sent(self, kind: str, size: int) -> None:
        entry = self.kinds.setdefault(kind, KindCount())
        entry.sent_msgs += 1
        entry.sent_bytes += size

    def count_received(self, kind: str, size: int) -> None:
        entry = self.kinds.setdefault(kind, KindCount())
        entry.recv_msgs += 1
        entry.recv_bytes += size

    def count_dropped(self, reason: str) -> None:
        self.dropped[reason] = self.dropped.get(reason, 0) + 1

    def sent(self, kind: str | None = None) -> int:
        return sum(c.sent_msgs for k, c in self.kinds.items() if kind in (None, k))

    def received(self, kind: str | None = None) -> int:
        return sum(c.recv_msgs for k, c in self.kinds.items() if kind in (None, k))

    def snapshot(self) -> dict[str, Any]:
        """A JSON-friendly copy, for run summaries."""
        return {
            "kinds": {
                k: {
                    "sent_msgs": c.sent_msgs,
                    "sent_bytes": c.sent_bytes,
                    "recv_msgs": c.recv_msgs,
                    "recv_bytes": c.recv_bytes,
                }
                for k, c in sorted(self.kinds.items())
            },
            "dropped": dict(sorted(self.dropped.items())),
        }


class Subscription:
    """A handle on one subscription; close it (or use `with`) to stop receiving."""

    def __init__(
        self,
        core: EndpointCore,
        key: int,
        callback: Callback | None,
        queue_limit: int,
    ) -> None:
        self._core = core
        self.key = key
        self._callback = callback
        self._queue: deque[Envelope] = deque()
        self._queue_limit = queue_limit
        self.overflowed = 0
        self.closed = False
        self.wake_on_replies = True
        """False: replies may wait until the owner polls for other reasons (see module doc)."""
        self.wake_on_traffic = True
        """False: nothing that arrives wakes the owner; it polls on its own timer (a bidder
        resting until it looks at the other bids) and queued datagrams wait for that poll."""

    @property
    def subjects(self) -> SubjectSet | None:
        """The subjects listened to; None for a monitor."""
        return self._core.subjects_of(self.key) if not self.closed else frozenset()

    def update(self, subjects: Iterable[str] | str | None) -> None:
        """Listen to `subjects` from now on (an empty set hears only subject-less messages)."""
        if self.closed:
            raise RuntimeError("subscription is closed")
        self._core.set_subjects(
            self.key, None if subjects is None else self._core.checked_subjects(subjects)
        )

    def drain(self) -> list[Envelope]:
        """Queued envelopes in arrival order (empty for callback subscriptions)."""
        items = list(self._queue)
        self._queue.clear()
        return items

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._core.remove(self.key)

    def __enter__(self) -> Subscription:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _deliver(self, envelope: Envelope) -> None:
        if self._callback is not None:
            self._callback(envelope)
            return
        if len(self._queue) >= self._queue_limit:
            self._queue.popleft()
            self.overflowed += 1
        self._queue.append(envelope)


class Transport(Protocol):
    """What the auction layer and the consensus allocators need from a transport."""

    @property
    def sender_id(self) -> str: ...

    @property
    def instance(self) -> str:
        """A nonce fixed when the transport was opened (differs across restarts)."""
        ...

    @property
    def counters(self) -> Counters: ...

    @property
    def codec(self) -> Codec: ...

    def publish(self, subjects: Iterable[str] | str, message: Any) -> int: ...

    def subscribe(
        self,
        subjects: Iterable[str] | str | None,
        callback: Callback | None = None,
        queue_limit: int = 4096,
    ) -> Subscription: ...

    def poll(self, timeout_s: float = 0.0) -> int: ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class TickConfig:
    """How an endpoint stamps and judges simulation ticks (see `murdoch.tick_order`).

    tick_clock: the owner's current simulation tick (stamped on every datagram it sends).
    epoch: the run's epoch token, stamped on every datagram; a receiver with an epoch drops
        datagrams of any other epoch (``wrong_epoch``).
    ordered: lockstep: hold received datagrams and act on them only at `release`, in tick
        order (a `TickInbox`); datagrams without a tick are dropped (``no_tick``).
    late_joiner: (ordered) this endpoint may have missed what was sent before it opened.
    stale_after_ticks: (not ordered) drop datagrams stamped more than this many ticks
        before the receiver's own tick (``stale``): a recorded datagram sent again later
        is refused even by a receiver that restarted since. 0: no limit.
    require_tick: drop datagrams without a tick (``no_tick``), e.g. in a keyed run.
    """

    tick_clock: Callable[[], int]
    epoch: str = ""
    ordered: bool = False
    late_joiner: bool = True
    stale_after_ticks: int = 0
    require_tick: bool = False


class EndpointCore:
    """Encoding, counting and the receive pipeline shared by all transports."""

    def __init__(
        self,
        sender_id: str,
        codec: Codec,
        clock: Clock,
        key: TeamKey | None = None,
        replay_window: int = 1024,
        instance: str | None = None,
        ticks: TickConfig | None = None,
    ) -> None:
        self.sender_id = check_token(sender_id, "sender_id")
        if instance is None:
            instance = os.urandom(4).hex()
        elif instance:
            check_token(instance, "instance")
        self.instance = instance
        self.codec = codec
        self.clock = clock
        self.key = key
        self.counters = Counters()
        self._replay = ReplayWindow(replay_window)
        self._index = SubjectIndex()
        self._monitors: set[int] = set()
        self._subs: dict[int, Subscription] = {}
        self._next_key = 0
        self._seq = 0
        self._matches: dict[SubjectSet, list[int]] = {}
        self._valid_sets: set[SubjectSet] = set()
        self._lock = threading.RLock()
        self.frame_tap: Callable[[Frame, int], None] | None = None
        """Called with every accepted frame and its size, known kind or not (for listeners)."""
        self._ratelog = RateLimitedLog(log, 10.0)
        self.ticks = ticks
        if ticks is not None and ticks.epoch:
            check_token(ticks.epoch, "epoch")
        self.inbox: TickInbox | None = (
            TickInbox(late_joiner=ticks.late_joiner)
            if ticks is not None and ticks.ordered else None)

    @property
    def sent_count(self) -> int:
        """Datagrams numbered so far (sequence numbers 0 .. sent_count - 1)."""
        return self._seq

    @property
    def sender_key(self) -> str:
        return sender_key(self.sender_id, self.instance)

    # -- subscriptions
    def subscribe(
        self,
        subjects: Iterable[str] | str | None,
        callback: Callback | None = None,
        queue_limit: int = 4096,
    ) -> Subscription:
        wanted = None if subjects is None else subject_set(subjects)
        with self._lock:
            key = self._next_key
            self._next_key += 1
            sub = Subscription(self, key, callback, queue_limit)
            self._subs[key] = sub
            self.set_subjects(key, wanted)
            return sub

    def subjects_of(self, key: int) -> SubjectSet | None:
        with self._lock:
            return None if key in self._monitors else self._index.subjects_of(key)

    @property
    def wants_traffic(self) -> bool:
        """Whether some open subscription (or a frame tap) must be woken by arrivals at all."""
        return self.frame_tap is not None or any(
            sub.wake_on_traffic for sub in list(self._subs.values())
        )

    @property
    def wants_replies(self) -> bool:
        """Whether some open subscription (or a frame tap) must be woken for replies."""
        return self.frame_tap is not None or any(
            sub.wake_on_traffic and sub.wake_on_replies for sub in list(self._subs.values())
        )

    def set_subjects(self, key: int, subjects: SubjectSet | None) -> None:
        with self._lock:
            self._matches.clear()
            if subjects is None:
                self._index.remove(key)
                self._monitors.add(key)
            else:
                self._monitors.discard(key)
                self._index.set(key, subjects)

    def remove(self, key: int) -> None:
        with self._lock:
            self._matches.clear()
            self._index.remove(key)
            self._monitors.discard(key)
            self._subs.pop(key, None)

    def checked_subjects(self, subjects: Iterable[str] | str) -> SubjectSet:
        """`subject_set(subjects)`, remembering the sets already checked (they recur)."""
        valid = self._valid_sets
        if type(subjects) is frozenset and subjects in valid:
            return subjects
        checked = subject_set(subjects)
        if len(valid) >= 1024:
            valid.clear()
        valid.add(checked)
        return checked

    # -- sending
    def encode(self, subjects: Iterable[str] | str, message: Any) -> bytes:
        """Datagram bytes for `message`, numbered, signed when keyed, and counted as sent."""
        subject_fs = self.checked_subjects(subjects)
        with self._lock:
            seq = self._seq
            ticks = self.ticks
            if ticks is None:
                data = self.codec.encode_frame(self.sender_id, seq, subject_fs, message,
                                               self.instance)
            else:
                data = self.codec.encode_frame(self.sender_id, seq, subject_fs, message,
                                               self.instance, ticks.tick_clock(), ticks.epoch)
            self._seq += 1
            if self.key is not None:
                data = self.key.sign(data)
            self.counters.count_sent(message.KIND, len(data))
        return data

    # -- receiving
    def match(self, subjects: SubjectSet) -> list[int]:
        """Keys of the subscriptions (monitors included) that hear `subjects`, sorted."""
        keys = self._matches.get(subjects)
        if keys is None:
            keys = self._index.match(subjects)
            if self._monitors:
                keys = sorted(set(keys) | self._monitors)
            if len(self._matches) >= 1024:
                self._matches.clear()
            self._matches[subjects] = keys
        return keys

    def receive(self, datagram: bytes) -> int:
        """Run one datagram through the pipeline; return how many subscriptions got it."""
        size = len(datagram)
        codec = self.codec
        key = self.key
        with self._lock:
            try:
                if size > codec.max_datagram_bytes:
                    raise WireError("too_large", f"{size} bytes")
                if key is not None and not is_signed(datagram):
                    raise WireError("auth_failed", "datagram carries no tag")
                header = codec.parse_header(datagram)
                ticks = self.ticks
                if ticks is not None:
                    self._check_tick(header, ticks)
                    if self.inbox is not None:
                        return self._hold(datagram, header, key)
            except WireError as exc:
                self._dropped(exc)
                return 0
        return self._deliver(datagram, header, key)

    def _deliver(self, datagram: bytes, header: Any, key: TeamKey | None) -> int:
        """Match, then (for datagrams someone listens to) authenticate with `key` (None:
        done already), decode, count and hand to the subscriptions."""
        size = len(datagram)
        codec = self.codec
        kind = header.kind
        with self._lock:
            try:
                keys = self._matches.get(header.subjects)
                if keys is None:
                    keys = self.match(header.subjects)
                tap = self.frame_tap
                if not keys and tap is None:
                    # nobody here listens: neither authenticated nor decoded, but counted
                    if not codec.knows(kind):
                        raise WireError("unknown_kind", f"kind {kind!r}")
                    self.counters.count_received(kind, size)
                    self.counters.count_dropped("unmatched")
                    return 0
                if key is not None:
                    key.check(datagram)
                    if not self._replay.accept(f"{header.sender}/{header.instance}",
                                               header.seq):
                        raise WireError("replayed", f"{header.sender}#{header.seq}")
                if tap is None:
                    message = codec.decode_message(datagram, header)
                else:
                    body = codec.decode_body(datagram, header)
                    tap(Frame(kind, header.sender, header.seq, header.subjects, body,
                              header.instance, header.tick, header.epoch), size)
                    if not keys:
                        if not codec.knows(kind):
                            raise WireError("unknown_kind", f"kind {kind!r}")
                        self.counters.count_received(kind, size)
                        self.counters.count_dropped("unmatched")
                        return 0
                    message = codec.message_from(kind, body)
            except WireError as exc:
                self._dropped(exc)
                return 0
            self.counters.count_received(kind, size)
            envelope = Envelope(header.sender, header.seq, header.subjects, message, size,
                                self.clock(), header.instance, header.tick)
            subs = self._subs
            if len(keys) == 1:
                only = subs[keys[0]]
                if only.closed:
                    return 1
                targets = None
            else:
                targets = [subs[k] for k in keys]
        if targets is None:
            only._deliver(envelope)
            return 1
        for sub in targets:
            if not sub.closed:
                sub._deliver(envelope)
        return len(targets)

    def _dropped(self, exc: WireError) -> None:
        """Count a refused datagram and say so in the log, once per reason per 10 s of the
        endpoint's clock (a flood of bad traffic cannot flood the log)."""
        self.counters.count_dropped(exc.reason)
        try:
            now = float(self.clock())
        except Exception:  # a clock that cannot answer (closing down): count only
            return
        self._ratelog.warning(exc.reason, now, "dropped a datagram: %s", exc)

    def _check_tick(self, header: Any, ticks: TickConfig) -> None:
        if ticks.epoch and header.epoch != ticks.epoch:
            raise WireError("wrong_epoch", f"epoch {header.epoch!r}")
        tick = header.tick
        if tick < 0:
            if ticks.require_tick or ticks.ordered:
                raise WireError("no_tick", f"{header.sender} sent no tick")
            return
        limit = ticks.stale_after_ticks
        if limit > 0 and not ticks.ordered and ticks.tick_clock() - tick > limit:
            raise WireError("stale", f"{header.sender}#{header.seq} from tick {tick}")

    def _hold(self, datagram: bytes, header: Any, key: TeamKey | None) -> int:
        """Lockstep: authenticate and keep a datagram for its release point (lock held)."""
        inbox = self.inbox
        assert inbox is not None
        if key is not None:
            key.check(datagram)
            if not self._replay.accept(f"{header.sender}/{header.instance}", header.seq):
                raise WireError("replayed", f"{header.sender}#{header.seq}")
        if not inbox.hold(header, datagram):
            raise WireError("replayed", f"{header.sender}#{header.seq} held already")
        return 0

    # -- lockstep release
    def missing(self, table: Mapping[str, int]) -> dict[str, int]:
        """Declared datagrams (count `table`) that have not arrived yet (see TickInbox)."""
        with self._lock:
            return self.inbox.missing(table) if self.inbox is not None else {}

    def start_tick(self, tick: int, table: Mapping[str, int]) -> None:
        with self._lock:
            if self.inbox is not None:
                self.inbox.start(tick, table)

    def settle(self, tick: int, table: Mapping[str, int], *, poll: Callable[[], object],
               wait: Callable[[float], object], wait_clock: Clock,
               give_up_after_s: float) -> int:
        """Lockstep: the release point of `tick` for a transport that reads with `poll()` and
        blocks up to a given time for input with `wait(seconds)`. Reads until every datagram
        that `table` declares through tick-1 is in, then acts on those stamped tick-1 or
        earlier (`release`). `wait_clock` only bounds the wait: a datagram still missing after
        `give_up_after_s` raises `LostDatagrams`."""
        self.start_tick(tick, table)
        # what is released depends only on the declared datagrams: when they are all held
        # already (most ticks nobody sent anything), the socket is not read here (the
        # node's own step reads it every tick, so it never fills)
        missing = self.missing(table)
        if missing:
            poll()
            missing = self.missing(table)
        if missing:
            deadline = wait_clock() + give_up_after_s
            while missing:
                left = deadline - wait_clock()
                if left <= 0:
                    self.counters.count_dropped("lost")
                    raise LostDatagrams(tick, missing)
                wait(min(left, 0.05))
                poll()
                missing = self.missing(table)
        return self.release(tick - 1, table)

    def release(self, through_tick: int, table: Mapping[str, int]) -> int:
        """Act on every held datagram stamped `through_tick` or earlier, in tick, sender,
        instance and sequence order: match, decode, count and deliver each (the time of
        delivery is the clock's now). Returns the deliveries made."""
        with self._lock:
            if self.inbox is None:
                return 0
            items = self.inbox.release(through_tick, table)
        delivered = 0
        for item in items:
            delivered += self._deliver(item.data, item.header, None)  # authenticated on hold
        return delivered

class EndpointBacked:
    """What every transport exposes straight from its `EndpointCore`: identity, counters
    and subscriptions."""

    _core: EndpointCore

    @property
    def sender_id(self) -> str:
        return self._core.sender_id

    @property
    def instance(self) -> str:
        return self._core.instance

    @property
    def counters(self) -> Counters:
        return self._core.counters

    @property
    def codec(self) -> Codec:
        return self._core.codec

    @property
    def core(self) -> EndpointCore:
        return self._core

    def subscribe(
        self,
        subjects: Iterable[str] | str | None,
        callback: Callback | None = None,
        queue_limit: int = 4096,
    ) -> Subscription:
        return self._core.subscribe(subjects, callback, queue_limit)
