"""The sans-IO dispatch core: bytes in, queued messages out, no sockets.

One ``ServerCore`` serves every endpoint (port) of a world. The TCP front end calls
``open_session`` on accept, ``receive`` with whatever bytes arrived, ``take_output``
when a socket can be written, ``close_session`` on disconnect; the stepping loop calls
``publish`` after each simulation tick and asks ``lockstep_ready`` whether it may step.

Data rounds (PULL mode): REQ DATA is ACKed at once; the round itself (the current DATA of
every subscribed device, then SYNCH OK) is sent as soon as a round newer than the
client's last one exists, i.e. a client sees each published round at most once and a
round never goes out empty (with nothing to send the round waits). In PUSH mode every
published round is queued for the client, subject to its replace rules (default:
REPLACE, the latest value wins).

Lockstep (the gate is ``LockstepGate``, in ``lockstep_gate.py``): when enabled, a
*participant* is a client in PULL mode that holds a position2d subscription, unless it set
the ``lockstep`` integer property of the ``player`` device (1 = always a participant, 0 =
never, -1 = automatic). The simulation
may step only when at least ``lockstep_clients`` participants have been seen since start
and every current participant has consumed the current round and asked for the next
one; with none left it waits, unless ``step_without_participants`` (a run's server, whose
team may all be gone) and none is expected either. A participant that holds the gate for
longer than ``lockstep_timeout_s`` (four times that before its first round) is demoted to
a monitor until its next REQ DATA (logged). Monitors never hold the gate. A participant
that has not asked for a round when it is published (one just put back into the lockstep)
is kept that round as published, and gets it when it asks.

Pipelined lockstep (``pipelined``): when the gate opens, the round of the current state
goes out first and the simulation steps after it, then the next round's data is computed
(``prepare``) while the clients work on theirs. The commands a client sends after round k
act in the step that leads from round k+1 to k+2 (one tick of actuation delay); the
schedule is fixed, so a seeded run still repeats exactly.

Limits (``CoreConfig``, docs/player.md "Hostile clients"): ``receive`` handles at most
``input_budget`` messages and leaves the rest for ``process`` on later turns
(``has_backlog``); a client with more than ``output_limit_bytes`` queued is closed; an
exception while handling a message is contained to it; the communication watchdog
(``server/watchdog.py``) hears every message and stops a device whose driving client fell
silent.
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from player_server.drivers.base import Driver, Reply, Unsupported
from player_server.protocol import constants as c
from player_server.protocol.codec import (
    NEED_DATA,
    Decoder,
    Undecodable,
    encode_message,
    encode_payload,
)
from player_server.protocol.constants import Interface, MsgType
from player_server.protocol.errors import EncodeError, FrameError
from player_server.protocol.header import HEADER_STRUCT, Message
from player_server.server.endpoint import Endpoint
from player_server.server.lockstep_gate import LockstepGate
from player_server.server.log_limit import LogLimiter
from player_server.server.out_queue import DataKey, OutQueue
from player_server.server.payloads import PayloadCache
from player_server.server.player_requests import PlayerRequests
from player_server.server.session import CoreConfig, CoreCounters, Session
from player_server.server.watchdog import CommandWatchdog

log = logging.getLogger(__name__)

_ACK = int(MsgType.RESP_ACK)
_NACK = int(MsgType.RESP_NACK)
_DATA = int(MsgType.DATA)
_REQ = int(MsgType.REQ)
_CMD = int(MsgType.CMD)
_PLAYER = int(Interface.PLAYER)
_SYNCH_OK = encode_message(_PLAYER, 0, int(MsgType.SYNCH), c.PLAYER_SYNCH_OK)
_pack_header = HEADER_STRUCT.pack
_SET_BOOLPROP_REQ = c.PLAYER_SET_BOOLPROP_REQ


def _rule(s: Session, key: DataKey) -> int:
    """The replace rule the client's first matching rule gives this DATA (REPLACE if none)."""
    hit = s.rule_of.get(key)
    if hit is not None:
        return hit
    interf, index, mtype, subtype = key
    rule = c.PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE
    for r in s.rules:
        if ((r.interf in (-1, interf)) and (r.index in (-1, index))
                and (r.type in (-1, mtype)) and (r.subtype in (-1, subtype))):
            rule = r.replace
            break
    s.rule_of[key] = rule
    return rule


def _device_ignored(s: Session, key: tuple[int, int]) -> bool:
    """Does the client's first rule for this device's DATA ignore every subtype?"""
    hit = s.ignored.get(key)
    if hit is not None:
        return hit
    interf, index = key
    ignored = False
    for r in s.rules:
        if r.interf in (-1, interf) and r.index in (-1, index) and r.type in (-1, _DATA):
            ignored = (r.subtype == -1
                       and r.replace == c.PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE)
            break
    s.ignored[key] = ignored
    return ignored


class ServerCore(PlayerRequests, LockstepGate):
    def __init__(
        self,
        endpoints: Sequence[Endpoint],
        sim_time_s: Callable[[], float],
        config: CoreConfig | None = None,
    ) -> None:
        self.endpoints = list(endpoints)
        self.config = config or CoreConfig()
        self._output_limit = self.config.output_limit_bytes
        self._sim_time_s = sim_time_s
        self._ids = itertools.count(1)
        self.sessions: dict[int, Session] = {}
        self.round_seq = 0
        self._cache: dict[tuple[int, int, int], tuple[Any, list[tuple[DataKey, bytes]]]] = {}
        self._payloads = PayloadCache()
        #: bumped whenever a driver handles a request or command (state may have changed)
        self._mutations = 0
        self.participants_seen = 0
        #: endpoints (by name) whose participant the lockstep waits for before it steps, each
        #: with a test of whether it can still come (its process is alive)
        self.expected: dict[str, Callable[[], bool]] = {}
        self.counters = CoreCounters()
        #: called with a session as soon as one of its rounds is queued (the front end
        #: writes it at once, so a client can start on its round while later ones are built)
        self.round_ready: Callable[[Session], None] | None = None
        self.limiter = LogLimiter(log)
        self.watchdog = CommandWatchdog(self.config.watchdog_s, sim_time_s)

    # -- sessions -------------------------------------------------------------------------
    def open_session(self, endpoint: Endpoint, peer: str = "") -> Session:
        s = Session(
            id=next(self._ids),
            endpoint=endpoint,
            decoder=Decoder(self.config.max_message_size),
            queue=OutQueue(self.config.queue_limit),
            peer=peer,
        )
        s.queue.push_reply(c.banner())
        self.sessions[s.id] = s
        self.counters.sessions_opened += 1
        return s

    def close_session(self, session: Session) -> None:
        """Forget a connection and everything it subscribed to."""
        session.subs.clear()
        session.has_live = False
        session.forget_plan()
        session.round_pending = False
        self.sessions.pop(session.id, None)
        self.watchdog.closed(session.id)

    def take_output(self, session: Session, max_bytes: int = 1 << 20) -> bytes:
        return session.queue.take(max_bytes)

    def has_output(self, session: Session) -> bool:
        return len(session.queue) > 0

    def accepting_input(self, session: Session) -> bool:
        return (
            session.closing is None
            and not session.backlog
            and session.queue.replies_waiting < self.config.max_replies_waiting
        )

    # -- input ----------------------------------------------------------------------------
    def receive(self, session: Session, data: bytes | bytearray | memoryview) -> None:
        """Feed bytes from a client and handle up to ``input_budget`` complete messages;
        the rest wait in the decoder (``has_backlog``) for ``process`` on a later turn."""
        if session.closing is not None:
            return
        session.decoder.feed(data)
        self.process(session)

    def has_backlog(self, session: Session) -> bool:
        """Did the client's last turn end with messages still to handle?"""
        return session.backlog and session.closing is None

    def process(self, session: Session) -> None:
        """Handle up to ``input_budget`` buffered messages of one client (its fair share of
        a loop turn: a client flooding requests cannot starve the others)."""
        budget = self.config.input_budget if self.config.input_budget > 0 else 1 << 62
        session.backlog = False
        next_event = session.decoder.next_event
        handled = 0
        try:
            while session.closing is None:
                if budget <= 0:
                    session.backlog = session.decoder.buffered > 0
                    session.counters.budget_exhausted += session.backlog
                    return
                try:
                    ev = next_event()
                except FrameError as exc:
                    self._unframeable(session, exc)
                    return
                if ev is NEED_DATA:
                    return
                budget -= 1
                handled += 1
                if type(ev) is not Message:
                    assert isinstance(ev, Undecodable)
                    self._bad(session, ev.header, ev.reason)
                    if ev.header.type == _REQ:
                        self._reply(session, ev.header.interf, ev.header.index,
                                    ev.header.subtype, None, ack=False)
                    continue
                replies_before = session.counters.replies
                try:
                    self._dispatch(session, ev)
                except Exception as exc:  # a driver bug must not take the server down
                    self.counters.internal_errors += 1
                    self.limiter.log("internal error", logging.ERROR,
                                     "error handling %s from %s on %s: %r", ev.header,
                                     session.peer, session.endpoint.name, exc, exc_info=True)
                    self._bad(session, ev.header, "internal error")
                    if ev.type == _REQ and session.counters.replies == replies_before:
                        self._reply(session, ev.interf, ev.index, ev.subtype, None,
                                    ack=False)
                # (whatever queued output checked the output limit: _reply, _try_round)
        finally:
            if handled:
                # the turn's messages were all heard at the same simulation time
                session.counters.messages_in += handled
                self.watchdog.heard(session.id, self._sim_time_s())

    def _unframeable(self, session: Session, exc: FrameError) -> None:
        self._bad(session, None, str(exc))
        session.closing = str(exc)
        self.counters.sessions_closed_bad_input += 1
        self.limiter.log("closing", logging.WARNING, "closing client %s on %s: %s",
                         session.peer, session.endpoint.name, exc)

    def _bad(self, session: Session, header: Any, reason: str) -> None:
        session.counters.bad_messages += 1
        self.counters.bad_messages += 1
        # a client sending garbage must not flood the log (the counters keep the tally)
        self.limiter.log("bad message", logging.WARNING,
                         "bad message #%d from %s on %s (%s): %s",
                         session.counters.bad_messages, session.peer, session.endpoint.name,
                         header, reason)

    def _reply(
        self, s: Session, interf: int, index: int, subtype: int, body: Any, *, ack: bool
    ) -> None:
        s.counters.replies += 1
        if not ack:
            s.counters.nacks += 1
        t = self._sim_time_s()
        robot = s.endpoint.port
        try:
            # what encode_message makes, packed here (one call less per reply)
            payload = b"" if body is None else encode_payload(body)
            try:
                wire = _pack_header(0, robot, interf, index, _ACK if ack else _NACK, subtype,
                                    t, 0, len(payload)) + payload
            except Exception as exc:
                raise EncodeError(f"bad header field: {exc}") from exc
        except EncodeError:
            log.exception("cannot encode the reply to %d:%d subtype %d", interf, index, subtype)
            wire = encode_message(interf, index, _NACK, subtype, None, timestamp=t, robot=robot)
        queue = s.queue
        queue.push_reply(wire)
        if queue.nbytes > self._output_limit > 0:
            self._check_output(s)

    def _dispatch(self, s: Session, msg: Message) -> None:
        h = msg.header
        interf, index, mtype, subtype = h[2], h[3], h[4], h[5]
        if interf == _PLAYER:
            if mtype == _REQ:
                s.counters.requests += 1
                self._player_request(s, msg)
            else:
                self._bad(s, h, "only requests go to the player device")
            return
        key = (interf, index)
        driver = s.endpoint.drivers.get(key)
        if mtype != _CMD or driver is None or subtype not in driver.deferred_commands:
            self._mutations += 1  # state may have changed: data is read afresh
        if mtype == _REQ:
            s.counters.requests += 1
            if driver is None:
                self._bad(s, h, "request to an unknown device")
                self._reply(s, interf, index, subtype, None, ack=False)
            elif key not in s.subs:
                self._bad(s, h, "request to a device not subscribed")
                self._reply(s, interf, index, subtype, None, ack=False)
            elif subtype >= _SET_BOOLPROP_REQ:
                self._universal_request(s, driver, msg)
            else:
                reply = self._call_driver_request(driver, subtype, msg.body)
                self._reply(s, interf, index, subtype, reply.body, ack=reply.ack)
        elif mtype == _CMD:
            s.counters.commands += 1
            if driver is None or key not in s.subs:
                self._bad(s, h, "command to an unknown or unsubscribed device")
                return
            try:
                driver.handle_command(h.subtype, msg.body)
            except Unsupported as exc:
                self.limiter.log("unsupported command", logging.INFO, "%s ignores command %d: %s",
                                 driver.driver_name, h.subtype, exc)
            except (ValueError, TypeError, KeyError, AttributeError, OverflowError) as exc:
                # a command with values the device refuses (NaN, out of range, ...)
                self.counters.commands_refused += 1
                self._bad(s, h, f"command refused by {driver.driver_name}: {exc}")
            else:
                if driver.watched:
                    self.watchdog.commanded(s.id, driver, s.endpoint.name)
        else:
            self._bad(s, h, f"clients do not send message type {h.type}")

    def _call_driver_request(self, driver: Driver, subtype: int, body: Any) -> Reply:
        try:
            return driver.handle_request(subtype, body)
        except Unsupported:
            return Reply(False)
        except (KeyError, ValueError, TypeError, AttributeError, OverflowError) as exc:
            self.limiter.log("refused request", logging.INFO, "%s refuses request %d: %s",
                             driver.driver_name, subtype, exc)
            return Reply(False)

    # -- data -------------------------------------------------------------------------------
    def _device_data(self, ep: Endpoint, key: tuple[int, int], driver: Driver,
                     version: tuple[float, int] | None = None) -> list[tuple[DataKey, bytes]]:
        # data depends only on simulation state: the same tick and no request or command
        # handled since means the same bytes (several clients, or rounds while paused)
        ck = (id(ep), key[0], key[1])
        if version is None:
            version = (self._sim_time_s(), self._mutations)
        hit = self._cache.get(ck)
        if hit is not None and hit[0] == version:
            return hit[1]
        out: list[tuple[DataKey, bytes]] = []
        wire = self._payloads.wire
        try:
            t = version[0]
            for subtype, body in driver.data():
                out.append(((key[0], key[1], _DATA, subtype),
                            wire(ck, key[0], key[1], subtype, body, t, ep.port)))
        except Exception as exc:  # contained to this device: the others still send theirs
            self.counters.driver_errors += 1
            self.limiter.log("driver data", logging.ERROR, "driver %s failed to produce data: %r",
                             driver.driver_name, exc, exc_info=True)
            out = []
        self._cache[ck] = (version, out)
        return out

    def _round_items(self, s: Session) -> Iterable[tuple[DataKey, bytes]]:
        version = (self._sim_time_s(), self._mutations)
        ep = s.endpoint
        rules = s.rules
        for key, driver in s.subs.items():
            if rules and _device_ignored(s, key):
                continue  # declined by the client: not even computed
            if driver.live:
                continue  # read when the round goes out (_live_bytes)
            yield from self._device_data(ep, key, driver, version)

    def _live_bytes(self, s: Session) -> bytes:
        """The DATA of the session's live devices, read now (they lead the round)."""
        out: list[bytes] = []
        t = self._sim_time_s()
        wire = self._payloads.wire
        for key, driver in s.subs.items():
            if not driver.live:
                continue
            try:
                out.extend(wire(driver, key[0], key[1], subtype, body, t, s.endpoint.port)
                           for subtype, body in driver.data())
            except Exception:
                log.exception("driver %s failed to produce data", driver.driver_name)
        return b"".join(out)

    def _round_bytes(self, s: Session) -> bytes | None:
        """A PULL round's DATA and SYNCH as one write; None when it has no DATA. Built once
        per data version (`prepare` builds it ahead of `publish`)."""
        version = (self._sim_time_s(), self._mutations)
        built = s.built
        if built is not None and built[0] == version:
            return built[1]
        reads = s.round_reads(_device_ignored)
        device_data = self._device_data
        ep = s.endpoint
        wires: list[bytes] = []
        if s.rules:
            ignore = c.PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE
            for key, driver in reads:
                wires.extend(wire for dkey, wire in device_data(ep, key, driver, version)
                             if _rule(s, dkey) != ignore)
        else:
            for key, driver in reads:
                for _dkey, wire in device_data(ep, key, driver, version):
                    wires.append(wire)
        # the DATA (encoded once per tick and device, shared by every client) and the
        # SYNCH leave as one queue entry, i.e. in the same write as what precedes them
        data = None
        if wires:
            wires.append(_SYNCH_OK)
            data = b"".join(wires)
        s.built = (version, data)
        return data

    def _try_round(self, s: Session) -> bool:
        """Send a pending PULL round if there is a newer round with data to send (the one
        kept for the session at its publication, if any: see `publish`)."""
        if not s.round_pending:
            return False
        owed, s.owed = s.owed, None
        seq = self.round_seq
        if owed is not None and owed[0] == seq:  # kept, and still the current round
            data: bytes | None = owed[1]
        elif s.last_round >= seq:
            return False
        else:
            data = self._whole_round(s)
        if data is None:
            return False
        s.queue.push_reply(data)
        self._check_output(s)
        s.round_pending = False
        s.last_round = seq
        s.counters.rounds += 1
        if self.round_ready is not None:
            self.round_ready(s)
        return True

    def _whole_round(self, s: Session) -> bytes | None:
        """The current round's bytes for a PULL session: its live devices read now, then
        the DATA and SYNCH built once per data version; None when it has no DATA."""
        data = self._round_bytes(s)
        if data is None or not s.has_live:
            return data
        return self._live_bytes(s) + data

    def publish(self) -> None:
        """A new round of data exists (the simulation stepped): push or serve it."""
        self.watchdog.check()
        self.round_seq += 1
        self.counters.rounds_published += 1
        for s in list(self.sessions.values()):
            if s.closing is not None:
                continue
            if s.mode == c.PLAYER_DATAMODE_PULL:
                if not self._try_round(s) and not s.round_pending and self.is_participant(s):
                    # a participant that has not asked yet (one just put back into the
                    # lockstep): the round is kept as it is now, so that when it asks it
                    # reads what the others read, not a later state or team clock table
                    kept = self._whole_round(s)
                    if kept is not None:
                        s.owed = (self.round_seq, kept)
            else:
                for dkey, wire in self._round_items(s):
                    rule = _rule(s, dkey)
                    if rule != c.PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE:
                        s.queue.push_data(
                            dkey, wire, rule == c.PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE)
                self._check_output(s)
                s.last_round = self.round_seq
                if self.round_ready is not None:
                    self.round_ready(s)

    def prepare(self) -> None:
        """Compute (and cache) the data of the next round for every PULL session now, so that
        publishing it later only sends bytes already made. Commands that only set targets
        keep the cache valid; anything else handled in between makes it read afresh."""
        for s in list(self.sessions.values()):
            if s.closing is None and s.mode == c.PLAYER_DATAMODE_PULL and s.subs:
                self._round_bytes(s)

    def rounds_wanted(self) -> bool:
        """Is some PULL client waiting for a round newer than the current one?"""
        seq = self.round_seq
        for s in self.sessions.values():
            if s.round_pending and s.last_round >= seq and s.closing is None:
                return True
        return False

    # -- limits ---------------------------------------------------------------------------
    def _check_output(self, s: Session) -> None:
        """A client that lets more than ``output_limit_bytes`` pile up unread is closed."""
        limit = self.config.output_limit_bytes
        if limit > 0 and s.closing is None and s.queue.nbytes > limit:
            s.closing = (f"output buffer limit exceeded ({s.queue.nbytes} bytes queued, "
                         f"limit {limit})")
            s.queue.clear()
            self.counters.closed_output_limit += 1
            self.limiter.log("output limit", logging.WARNING, "closing client %s on %s: %s",
                             s.peer, s.endpoint.name, s.closing)

    def stats(self) -> dict[str, Any]:
        return {
            "sessions": len(self.sessions),
            "round_seq": self.round_seq,
            "participants": len(self.participants()),
            "watchdog_stops": self.watchdog.stops,
            **vars(self.counters),
        }
