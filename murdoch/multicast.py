"""UDP multicast transport, loopback only unless configured otherwise.

Defaults keep every datagram on this host: the sending interface (`IP_MULTICAST_IF`) is
127.0.0.1, the TTL is 0, the group is joined on 127.0.0.1 only, and `IP_MULTICAST_LOOP` is on
so that the sender's own host (and the sender itself) hears it. `SO_REUSEADDR` and
`SO_REUSEPORT` let several processes on one host bind the same group and port, and each gets
its own copy of every datagram. The socket is bound to the group address, so it sees nothing
but that group's traffic, and `IP_MULTICAST_ALL` is switched off where the platform has it.

`poll(timeout_s)` waits at most `timeout_s` for the first datagram (select), then reads and
dispatches everything already queued. There is no background thread: the owner's loop polls.
"""

from __future__ import annotations

import ipaddress
import logging
import select
import socket
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from murdoch.auth import TeamKey
from murdoch.transport import (
    Clock,
    EndpointBacked,
    EndpointCore,
)
from murdoch.wire import Codec

log = logging.getLogger(__name__)

DEFAULT_GROUP = "239.255.74.17"
DEFAULT_PORT = 47017
LOOPBACK = "127.0.0.1"
_IP_MULTICAST_ALL = getattr(socket, "IP_MULTICAST_ALL", 49)
_RECV_BUFFER_BYTES = 1 << 20


@dataclass(frozen=True)
class MulticastConfig:
    group: str = DEFAULT_GROUP
    port: int = DEFAULT_PORT
    interface: str = LOOPBACK
    ttl: int = 0

    def __post_init__(self) -> None:
        group = ipaddress.ip_address(self.group)
        if not (isinstance(group, ipaddress.IPv4Address) and group.is_multicast):
            raise ValueError(f"{self.group} is not an IPv4 multicast group")
        if not 1 <= self.port <= 65535:
            raise ValueError(f"port {self.port} out of range")
        if self.ttl not in (0, 1):
            raise ValueError(f"ttl must be 0 or 1 (found {self.ttl}); traffic stays local")
        ipaddress.IPv4Address(self.interface)


def open_multicast_socket(config: MulticastConfig) -> socket.socket:
    """A non-blocking UDP socket joined to the group on the configured interface."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if hasattr(socket, "SO_REUSEPORT"):
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, _RECV_BUFFER_BYTES)
        sock.bind((config.group, config.port))
        iface = socket.inet_aton(config.interface)
        sock.setsockopt(
            socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, socket.inet_aton(config.group) + iface
        )
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, iface)
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, config.ttl)
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
        try:
            sock.setsockopt(socket.IPPROTO_IP, _IP_MULTICAST_ALL, 0)
        except OSError:
            log.debug("IP_MULTICAST_ALL not supported here")
        sock.setblocking(False)
    except BaseException:
        sock.close()
        raise
    return sock


class MulticastTransport(EndpointBacked):
    """A `Transport` over one UDP multicast group and port."""

    def __init__(
        self,
        sender_id: str,
        clock: Clock,
        config: MulticastConfig | None = None,
        codec: Codec | None = None,
        key: TeamKey | None = None,
        instance: str | None = None,
    ) -> None:
        from murdoch.auction.messages import AUCTION_CODEC

        self.config = config or MulticastConfig()
        self._core = EndpointCore(
            sender_id, codec or AUCTION_CODEC, clock, key, instance=instance
        )
        self._sock = open_multicast_socket(self.config)
        self._dest = (self.config.group, self.config.port)
        self.closed = False

    def fileno(self) -> int:
        return self._sock.fileno()

    def publish(self, subjects: Iterable[str] | str, message: Any) -> int:
        if self.closed:
            raise RuntimeError("transport is closed")
        data = self._core.encode(subjects, message)
        self.send_raw(data)
        return len(data)

    def send_raw(self, datagram: bytes) -> None:
        """Send bytes to the group as they are (tests use it for forged traffic)."""
        try:
            self._sock.sendto(datagram, self._dest)
        except BlockingIOError:
            ready = select.select([], [self._sock], [], 0.05)[1]
            if not ready:
                self._core.counters.count_dropped("send_blocked")
                return
            self._sock.sendto(datagram, self._dest)

    def poll(self, timeout_s: float = 0.0, max_datagrams: int = 10_000) -> int:
        if self.closed:
            return 0
        if timeout_s > 0:
            ready = select.select([self._sock], [], [], timeout_s)[0]
            if not ready:
                return 0
        delivered = 0
        for _ in range(max_datagrams):
            try:
                datagram = self._sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                break
            delivered += self._core.receive(datagram)
        return delivered

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._sock.close()

    def __enter__(self) -> MulticastTransport:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
