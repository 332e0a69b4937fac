"""UDP multicast transport, loopback only unless configured otherwise.

Defaults keep every datagram on this host: the sending interface (`IP_MULTICAST_IF`) is
127.0.0.1, the TTL is 0, the groups are joined on 127.0.0.1 only, and `IP_MULTICAST_LOOP` is on
so that the sender's own host (and the sender itself) hears it. `SO_REUSEADDR` and
`SO_REUSEPORT` let several processes on one host bind the same group and port, and each gets
its own copy of every datagram. Each socket is bound to its group address, so it sees nothing
but that group's traffic, and `IP_MULTICAST_ALL` is switched off where the platform has it.

By default one group and one port carry everything. As an option
(`MulticastConfig(reply_lane=True)`) a second group on the same port, the *reply lane*, carries
the replies (message classes with ``REPLY = True``: bids, awards, progress, reports; by
default the address after the main group), everything else stays on the main group. Every
member of a team must then use the lane, since processes without it never join the reply
group. With the lane every transport joins and reads both groups; the lanes only decide who
is woken. A transport waits for replies only while a subscription asks for it
(`wake_on_replies`; a `Node` asks while its auctioneer has open tasks or its bidder holds a bid
still in contention); otherwise queued replies are read at its next poll, before the main
lane's traffic. So bidders are not woken by each other's bids, yet see them all before the
award that follows them. With one group every datagram wakes the process (the flag asks for
no more than that), unless every subscription rests (`wake_on_traffic` False): then a poll
waits on no socket at all, only its timeout, and reads both lanes afterwards.

`poll(timeout_s)` waits at most `timeout_s` for the first datagram (select), then reads and
dispatches everything already queued, on both lanes when there are two (non-blocking reads
until EAGAIN). There is no background thread: the owner's loop polls.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import logging
import select
import socket
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from murdoch.endpoint import EndpointOptions, NetworkEndpoint
from murdoch.lossy import LossyReceiver
from murdoch.transport import (
    Clock,
)

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
    reply_lane: bool = False
    """Carry replies (bids, awards, progress, reports) on a second group on the same port."""
    reply_group: str | None = None
    """The reply lane's group; None: the address after `group` (before it for the last)."""

    def __post_init__(self) -> None:
        group = ipaddress.ip_address(self.group)
        if not (isinstance(group, ipaddress.IPv4Address) and group.is_multicast):
            raise ValueError(f"{self.group} is not an IPv4 multicast group")
        if self.reply_group is not None:
            reply = ipaddress.ip_address(self.reply_group)
            if not (isinstance(reply, ipaddress.IPv4Address) and reply.is_multicast):
                raise ValueError(f"{self.reply_group} is not an IPv4 multicast group")
            if reply == group:
                raise ValueError("the reply group must differ from the main group")
        if not 1 <= self.port <= 65535:
            raise ValueError(f"port {self.port} out of range")
        if self.ttl not in (0, 1):
            raise ValueError(f"ttl must be 0 or 1 (found {self.ttl}); traffic stays local")
        ipaddress.IPv4Address(self.interface)

    @property
    def replies_group(self) -> str:
        """The reply lane's group address (explicit or derived from `group`)."""
        if self.reply_group is not None:
            return self.reply_group
        group = ipaddress.IPv4Address(self.group)
        after = group + 1 if int(group) < int(ipaddress.IPv4Address("239.255.255.255")) else None
        return str(after if after is not None and after.is_multicast else group - 1)

    def reply_config(self) -> MulticastConfig:
        """This configuration with the lanes swapped (to open a socket on the reply lane)."""
        return dataclasses.replace(self, group=self.replies_group, reply_group=self.group)


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


class MulticastTransport(NetworkEndpoint):
    """A `Transport` over one UDP multicast group and port (plus the reply group when the
    configuration turns the reply lane on)."""

    def __init__(
        self,
        sender_id: str,
        clock: Clock,
        config: MulticastConfig | None = None,
        options: EndpointOptions | None = None,
        loss: LossyReceiver | None = None,
    ) -> None:
        options = options or EndpointOptions()
        if loss is not None and options.ticks is not None and options.ticks.ordered:
            raise ValueError("a loss layer cannot be used in lockstep (ordered ticks): a "
                             "lost datagram is an error there")
        self.loss = loss

        self.config = config or MulticastConfig()
        self._core = options.core(sender_id, clock)
        self._sock = open_multicast_socket(self.config)
        self._dest = (self.config.group, self.config.port)
        self._reply_sock: socket.socket | None = None
        if self.config.reply_lane:
            try:
                self._reply_sock = open_multicast_socket(self.config.reply_config())
            except BaseException:
                self._sock.close()
                raise
            self._reply_dest = (self.config.replies_group, self.config.port)
            self._both = [self._sock, self._reply_sock]
            self._read_order: tuple[socket.socket, ...] = (self._reply_sock, self._sock)
        else:
            self._reply_dest = self._dest
            self._both = [self._sock]
            self._read_order = (self._sock,)
        self._main_only = [self._sock]
        self._nothing: list[socket.socket] = []
        self.closed = False

    def fileno(self) -> int:
        """The main lane's socket (what a caller's own select should wait on)."""
        return self._sock.fileno()

    def publish(self, subjects: Iterable[str] | str, message: Any) -> int:
        if self.closed:
            raise RuntimeError("transport is closed")
        data = self._core.encode(subjects, message)
        self.send_raw(data, reply=self._core.codec.is_reply(message.KIND))
        return len(data)

    def send_raw(self, datagram: bytes, reply: bool = False) -> None:
        """Send bytes as they are, to where replies go when `reply` (the reply group if the
        lane is on, else the one group) or to the main group (tests use it for forged
        traffic)."""
        dest = self._reply_dest if reply else self._dest
        try:
            self._sock.sendto(datagram, dest)
        except BlockingIOError:
            ready = select.select([], [self._sock], [], 0.05)[1]
            if not ready:
                self._core.counters.count_dropped("send_blocked")
                return
            self._sock.sendto(datagram, dest)

    def poll(self, timeout_s: float = 0.0, max_datagrams: int = 10_000) -> int:
        """Wait up to `timeout_s` for traffic the subscriptions must be woken for, then read
        everything queued (both lanes, replies first, when there are two); return deliveries
        made."""
        if self.closed:
            return 0
        core = self._core
        if timeout_s > 0:
            if not core.wants_traffic:
                waits = self._nothing  # every subscription rests: only the timeout ends the wait
            elif self._reply_sock is not None and not core.wants_replies:
                waits = self._main_only
            else:
                waits = self._both
            select.select(waits, [], [], timeout_s)
        limit = core.codec.max_datagram_bytes + 1  # longer ones are truncated: too_large
        receive = core.receive
        delivered = 0
        budget = max_datagrams
        loss = self.loss
        for sock in self._read_order:
            recv = sock.recv
            while budget > 0:
                try:
                    datagram = recv(limit)
                except (BlockingIOError, InterruptedError):
                    break
                budget -= 1
                if loss is not None:
                    loss.offer(datagram)
                else:
                    delivered += receive(datagram)
        if loss is not None:
            for datagram in loss.due():
                delivered += receive(datagram)
        return delivered

    def _wait(self, timeout_s: float) -> None:
        select.select(self._both, [], [], timeout_s)

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._sock.close()
            if self._reply_sock is not None:
                self._reply_sock.close()
