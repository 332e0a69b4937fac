"""The server core's requests to the player device and the universal property requests.

`PlayerRequests` is the part of `player_server.server.core.ServerCore` that answers a
client's requests to the player device (data, device list, driver info, subscriptions,
data modes, replace rules, capabilities, properties of the player device) and the universal
property requests (GET/SET_INT/DBL/STR/BOOLPROP) to any device.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from player_server.drivers.base import Driver
from player_server.protocol import constants as c
from player_server.protocol import player_msgs as pm
from player_server.protocol.common import DevAddr
from player_server.protocol.constants import Interface
from player_server.protocol.header import Message

if TYPE_CHECKING:
    from player_server.server.log_limit import LogLimiter
    from player_server.server.session import CoreConfig, CoreCounters, Session

# the core's logger: these are its messages
log = logging.getLogger("player_server.server.core")

LOCKSTEP_PROPERTY = "lockstep"
_PLAYER = int(Interface.PLAYER)
_PROP_TYPES: dict[int, type] = {
    c.PLAYER_GET_INTPROP_REQ: int, c.PLAYER_SET_INTPROP_REQ: int,
    c.PLAYER_GET_DBLPROP_REQ: float, c.PLAYER_SET_DBLPROP_REQ: float,
    c.PLAYER_GET_STRPROP_REQ: str, c.PLAYER_SET_STRPROP_REQ: str,
    c.PLAYER_GET_BOOLPROP_REQ: bool, c.PLAYER_SET_BOOLPROP_REQ: bool,
}
_PROP_GETS = {c.PLAYER_GET_INTPROP_REQ, c.PLAYER_GET_DBLPROP_REQ, c.PLAYER_GET_STRPROP_REQ,
              c.PLAYER_GET_BOOLPROP_REQ}


class PlayerRequests:
    """Request handling of `ServerCore` (which provides what is declared below)."""

    if TYPE_CHECKING:
        config: CoreConfig
        counters: CoreCounters
        limiter: LogLimiter

        def _reply(self, s: Session, interf: int, index: int, subtype: int, body: Any, *,
                   ack: bool) -> None: ...

        def _try_round(self, s: Session) -> bool: ...

        def is_participant(self, s: Session) -> bool: ...

    def _player_request(self, s: Session, msg: Message) -> None:
        st, body = msg.subtype, msg.body
        ep = s.endpoint
        if st == c.PLAYER_REQ_DATA:
            self._reply(s, _PLAYER, msg.index, st, None, ack=True)
            if s.mode == c.PLAYER_DATAMODE_PULL:
                s.round_pending = True
                s.stalled_since = None
                if s.demoted:
                    s.demoted = False
                    log.info("lockstep: client %s on %s holds the clock again", s.peer,
                             s.endpoint.name)
                self._try_round(s)
        elif st == c.PLAYER_REQ_DEV and isinstance(body, pm.DeviceReq):
            self._dev_request(s, msg.index, body)
        elif st == c.PLAYER_REQ_DATAMODE and isinstance(body, pm.DeviceDatamodeReq):
            if body.mode in (c.PLAYER_DATAMODE_PUSH, c.PLAYER_DATAMODE_PULL):
                s.mode = body.mode
                if s.mode == c.PLAYER_DATAMODE_PUSH:
                    s.round_pending = False
                else:
                    s.queue.clear_data()
            else:
                log.warning("unknown data mode %d from %s", body.mode, s.peer)
            self._reply(s, _PLAYER, msg.index, st, None, ack=True)
        elif st == c.PLAYER_REQ_DEVLIST:
            devs = tuple(DevAddr(0, ep.port, i, x) for (i, x) in ep.drivers)
            self._reply(s, _PLAYER, msg.index, st, pm.DeviceDevlist(devs), ack=True)
        elif st == c.PLAYER_REQ_DRIVERINFO and isinstance(body, pm.DeviceDriverInfo):
            drv = ep.drivers.get((body.addr.interf, body.addr.index))
            if drv is None:
                self._reply(s, _PLAYER, msg.index, st, None, ack=False)
            else:
                addr = DevAddr(0, ep.port, body.addr.interf, body.addr.index)
                self._reply(s, _PLAYER, msg.index, st,
                            pm.DeviceDriverInfo(addr, drv.driver_name), ack=True)
        elif st == c.PLAYER_REQ_ADD_REPLACE_RULE and isinstance(body, pm.AddReplaceRuleReq):
            if len(s.rules) >= self.config.max_rules:
                self.counters.rules_refused += 1
                self.limiter.log("rules", logging.WARNING,
                                 "client %s on %s: more than %d replace rules refused",
                                 s.peer, s.endpoint.name, self.config.max_rules)
                self._reply(s, _PLAYER, msg.index, st, None, ack=False)
            elif body.replace in (0, 1, 2):
                s.rules.append(body)
                s.forget_plan()
                self._reply(s, _PLAYER, msg.index, st, None, ack=True)
            else:
                self._reply(s, _PLAYER, msg.index, st, None, ack=False)
        elif st in (c.PLAYER_SET_INTPROP_REQ, c.PLAYER_GET_INTPROP_REQ) and isinstance(
            body, pm.IntPropReq
        ) and body.key == LOCKSTEP_PROPERTY:
            if st == c.PLAYER_SET_INTPROP_REQ:
                s.lockstep_override = None if body.value < 0 else bool(body.value)
                self._reply(s, _PLAYER, msg.index, st, None, ack=True)
            else:
                value = int(self.is_participant(s))
                self._reply(s, _PLAYER, msg.index, st,
                            pm.IntPropReq(body.key, value), ack=True)
        else:
            # AUTH, NAMESERVICE, unknown subtypes and bodies that do not fit
            self._reply(s, _PLAYER, msg.index, st, None, ack=False)

    def _dev_request(self, s: Session, index: int, body: pm.DeviceReq) -> None:
        ep = s.endpoint
        key = (body.addr.interf, body.addr.index)
        drv = ep.drivers.get(key)
        addr = DevAddr(0, ep.port, body.addr.interf, body.addr.index)
        st = c.PLAYER_REQ_DEV
        if drv is None or body.access not in (c.PLAYER_OPEN_MODE, c.PLAYER_CLOSE_MODE):
            self._reply(s, _PLAYER, index, st,
                        pm.DeviceReq(addr, c.PLAYER_ERROR_MODE, ""), ack=False)
            return
        if body.access == c.PLAYER_OPEN_MODE:
            s.subs[key] = drv
        else:
            s.subs.pop(key, None)
        s.has_live = any(d.live for d in s.subs.values())
        s.forget_plan()
        self._reply(s, _PLAYER, index, st, pm.DeviceReq(addr, body.access, drv.driver_name),
                    ack=True)
        if body.access == c.PLAYER_OPEN_MODE and s.round_pending:
            self._try_round(s)

    def _universal_request(self, s: Session, driver: Driver, msg: Message) -> None:
        st, body, h = msg.subtype, msg.body, msg.header
        if st == c.PLAYER_CAPABILITIES_REQ and isinstance(body, pm.CapabilitiesReq):
            ok = driver.supports(body.type, body.subtype)
            self._reply(s, h.interf, h.index, st, None, ack=ok)
            return
        want = _PROP_TYPES.get(st)
        key = getattr(body, "key", None)
        if want is None or key is None:
            self._reply(s, h.interf, h.index, st, None, ack=False)
            return
        try:
            if st in _PROP_GETS:
                value = driver.get_property(key)
                if want is float and isinstance(value, int) and not isinstance(value, bool):
                    value = float(value)
                if want is bool and isinstance(value, bool):
                    value = int(value)
                elif type(value) is not want:
                    raise TypeError(f"property {key!r} is a {type(value).__name__}")
                self._reply(s, h.interf, h.index, st, type(body)(key, value), ack=True)
            else:
                value = bool(body.value) if want is bool else body.value
                driver.set_property(key, value)
                self._reply(s, h.interf, h.index, st, None, ack=True)
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            self.limiter.log("refused property", logging.INFO,
                             "property request %d %r on %s refused: %s", st, key,
                             driver.driver_name, exc)
            self._reply(s, h.interf, h.index, st, None, ack=False)
