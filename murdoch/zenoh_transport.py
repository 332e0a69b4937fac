"""MURDOCH over Eclipse Zenoh: a `Transport` for networks that multicast does not reach.

Optional: needs the `eclipse-zenoh` package (``pip install murdoch[zenoh]``). The datagrams are
exactly the multicast transport's (same header, body, HMAC tag, sequence numbers and tick
stamps, built and judged by the shared `EndpointCore`); Zenoh only moves the bytes.

Topology: a star. One process of the team is the *hub*: its session runs in Zenoh's router
mode and listens on the configured endpoint; every other process opens a client session
that connects to it, declares its subscription, then asks the hub a question on the same
link and waits for the answer: the hub reads a link in order, so once it has answered it
routes the team's datagrams to the new client, and a transport that has opened misses
nothing sent after that (as a multicast socket that has joined its group). The router
forwards each publication to every session with a matching Zenoh subscription, so one put
reaches the whole team (the publisher's own subscriptions are served inside its session,
as multicast loops a datagram back to its sender).

Addressing: every datagram of a team goes to one key expression (``<prefix>/bus``), and the
subject-set match (a message reaches each subscription holding all its subjects) is made by
the receive pipeline from the datagram's header, as on multicast; so forged, malformed,
replayed or unmatched datagrams are refused and counted in the same `Counters`.

Network safety: multicast scouting and gossip are off; the hub listens, and the clients
connect, only on the configured ``tcp/ADDRESS:PORT`` endpoint, which must be on 127.0.0.1
unless the configuration says `allow_remote` (a routed deployment chosen on purpose).

Threads: Zenoh calls the subscription's callback on its own thread; that callback only
appends the bytes to a bounded queue and wakes the owner. Everything else (matching,
authentication, decoding, delivery) happens in `poll`, on the owner's thread, as with
multicast. Lockstep runs use `settle_tick` exactly as on multicast: the tick order is the
`EndpointCore`'s, and Zenoh's links are reliable and keep each sender's order.
"""

from __future__ import annotations

import ipaddress
import json
import re
import threading
import time
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from murdoch.endpoint import EndpointOptions, NetworkEndpoint
from murdoch.transport import Clock

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
DEFAULT_PREFIX = "murdoch/team"
_ENDPOINT = re.compile(r"^tcp/(?P<host>[0-9.]+):(?P<port>[0-9]{1,5})$")
_PREFIX = re.compile(r"^[a-z0-9][a-z0-9_-]*(/[a-z0-9][a-z0-9_-]*)*$")
_QUEUE_LIMIT = 65536


class ZenohUnavailable(RuntimeError):
    """The optional `eclipse-zenoh` package is not installed."""


def parse_endpoint(text: str, allow_remote: bool = False) -> tuple[str, int]:
    """(address, port) of a ``tcp/ADDRESS:PORT`` endpoint, or ValueError naming what is wrong."""
    match = _ENDPOINT.match(text)
    if match is None:
        raise ValueError(f"zenoh endpoint {text!r}: expected tcp/ADDRESS:PORT, e.g. "
                         f"{DEFAULT_ENDPOINT}")
    try:
        address = ipaddress.IPv4Address(match["host"])
    except ValueError:
        raise ValueError(f"zenoh endpoint {text!r}: {match['host']!r} is not an IPv4 "
                         "address") from None
    port = int(match["port"])
    if not 1 <= port <= 65535:
        raise ValueError(f"zenoh endpoint {text!r}: port {port} out of range")
    if not allow_remote and str(address) != "127.0.0.1":
        raise ValueError(f"zenoh endpoint {text!r}: only 127.0.0.1 is allowed unless remote "
                         "endpoints are allowed explicitly")
    return str(address), port


@dataclass(frozen=True)
class ZenohConfig:
    """Where the team's Zenoh hub is and whether this process is it."""

    endpoint: str = DEFAULT_ENDPOINT
    hub: bool = False
    """True: this session is the team's router and listens on `endpoint`; False: a client
    that connects to it."""
    prefix: str = DEFAULT_PREFIX
    """The team's key-expression prefix (teams on one hub are kept apart by it)."""
    allow_remote: bool = False
    connect_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        parse_endpoint(self.endpoint, self.allow_remote)
        if not _PREFIX.match(self.prefix):
            raise ValueError(f"zenoh prefix {self.prefix!r}: expected words of a-z 0-9 _ - "
                             "separated by '/'")
        if self.connect_timeout_s <= 0:
            raise ValueError("connect_timeout_s must be > 0")

    @property
    def key_expr(self) -> str:
        return f"{self.prefix}/bus"

    @property
    def hub_key_expr(self) -> str:
        """Where the hub answers a joining client (see `ZenohTransport`)."""
        return f"{self.prefix}/hub"

    def session_settings(self) -> dict[str, Any]:
        """The Zenoh configuration entries this transport sets (loopback unless allowed)."""
        timeout_ms = int(self.connect_timeout_s * 1000)
        return {
            "mode": "router" if self.hub else "client",
            "listen/endpoints": [self.endpoint] if self.hub else [],
            "connect/endpoints": [] if self.hub else [self.endpoint],
            "connect/timeout_ms": timeout_ms,
            "scouting/multicast/enabled": False,
            "scouting/gossip/enabled": False,
        }


def _zenoh() -> Any:
    try:
        import zenoh
    except ImportError:
        raise ZenohUnavailable(
            "the zenoh transport needs the eclipse-zenoh package: pip install "
            "'murdoch[zenoh]'") from None
    return zenoh


def open_session(config: ZenohConfig) -> Any:
    """A Zenoh session set up as `config` says (raises ZenohUnavailable without zenoh)."""
    zenoh = _zenoh()
    settings = zenoh.Config()
    for key, value in config.session_settings().items():
        settings.insert_json5(key, json.dumps(value))
    try:
        return zenoh.open(settings)
    except Exception as exc:  # zenoh raises its own error type
        role = "listen on" if config.hub else "connect to"
        raise OSError(f"zenoh: cannot {role} {config.endpoint}: {exc}") from None


class ZenohTransport(NetworkEndpoint):
    """A `Transport` over a Zenoh session (hub or client, see the module doc)."""

    def __init__(
        self,
        sender_id: str,
        clock: Clock,
        config: ZenohConfig | None = None,
        options: EndpointOptions | None = None,
    ) -> None:
        self.config = config or ZenohConfig()
        self._core = (options or EndpointOptions()).core(sender_id, clock)
        self._queue: deque[bytes] = deque()
        self._closing = threading.Event()
        self._arrived = threading.Condition()
        self.overflowed = 0
        self._overflow_counted = 0
        self.closed = False
        self._session = open_session(self.config)
        self._queryable: Any = None
        try:
            self._subscriber = self._session.declare_subscriber(
                self.config.key_expr, self._on_sample)
            if self.config.hub:
                self._queryable = self._session.declare_queryable(
                    self.config.hub_key_expr, self._answer)
            else:
                self._wait_for_hub()
        except BaseException:
            self._session.close()
            raise

    # -- joining: a client's subscription is the hub's to route before the client goes on
    @staticmethod
    def _answer(query: Any) -> None:
        query.reply(query.key_expr, b"hub")

    def _wait_for_hub(self) -> None:
        """Ask the hub a question on the link that carried the subscription: the hub reads
        that link in order, so once it answers it routes the team's datagrams to this
        session (nothing sent after this returns can miss it)."""
        deadline = time.monotonic() + self.config.connect_timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise OSError(f"zenoh: no hub answered at {self.config.endpoint} "
                              f"({self.config.hub_key_expr})")
            try:
                replies = list(self._session.get(self.config.hub_key_expr,
                                                 timeout=min(left, 2.0)))
            except Exception as exc:  # zenoh raises its own error type
                raise OSError(f"zenoh: asking the hub at {self.config.endpoint} failed: "
                              f"{exc}") from None
            if any(reply.ok is not None for reply in replies):
                return
            self._closing.wait(0.05)

    # -- Zenoh's thread: queue the bytes, wake the owner
    def _on_sample(self, sample: Any) -> None:
        data = bytes(sample.payload.to_bytes())
        with self._arrived:
            if len(self._queue) >= _QUEUE_LIMIT:
                self._queue.popleft()
                self.overflowed += 1
            self._queue.append(data)
            self._arrived.notify_all()

    def publish(self, subjects: Iterable[str] | str, message: Any) -> int:
        if self.closed:
            raise RuntimeError("transport is closed")
        data = self._core.encode(subjects, message)
        self.send_raw(data)
        return len(data)

    def send_raw(self, datagram: bytes) -> None:
        """Put bytes on the team's key as they are (tests use it for forged traffic). A put
        Zenoh refuses (a closed session) is an OSError, as a failed send is on multicast."""
        try:
            self._session.put(self.config.key_expr, datagram)
        except Exception as exc:  # zenoh raises its own error type
            raise OSError(f"zenoh: put on {self.config.key_expr} failed: {exc}") from None

    def _wait(self, timeout_s: float) -> None:
        with self._arrived:
            if not self._queue:
                self._arrived.wait(timeout_s)

    def poll(self, timeout_s: float = 0.0, max_datagrams: int = 10_000) -> int:
        """Wait up to `timeout_s` for a datagram (only the timeout while every subscription
        rests), then run everything queued through the pipeline; return deliveries made."""
        if self.closed:
            return 0
        core = self._core
        if timeout_s > 0:
            if core.wants_traffic:
                self._wait(timeout_s)
            else:  # every subscription rests: only the timeout (or close) ends the wait
                self._closing.wait(timeout_s)
        lost = self.overflowed - self._overflow_counted
        if lost:  # the queue was full: the oldest datagrams went (counted here, by the owner)
            self._overflow_counted += lost
            for _ in range(lost):
                core.counters.count_dropped("queue_overflow")
        delivered = 0
        receive = core.receive
        for _ in range(max_datagrams):
            with self._arrived:
                if not self._queue:
                    break
                datagram = self._queue.popleft()
            delivered += receive(datagram)
        return delivered

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._closing.set()
            try:
                self._subscriber.undeclare()
                if self._queryable is not None:
                    self._queryable.undeclare()
            finally:
                self._session.close()
            with self._arrived:
                self._queue.clear()
                self._arrived.notify_all()
