"""What the server core keeps per client and in all: its configuration, one `Session` per
connection (subscriptions, data mode, replace rules, queue, round state) and the counters."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from player_server.drivers.base import Driver
from player_server.protocol import constants as c
from player_server.protocol import player_msgs as pm
from player_server.protocol.codec import Decoder
from player_server.server.endpoint import Endpoint
from player_server.server.out_queue import DataKey, OutQueue


@dataclass(frozen=True)
class CoreConfig:
    lockstep: bool = False
    lockstep_clients: int = 1
    lockstep_timeout_s: float = 30.0
    #: lockstep only: publish the current round first, then step and prepare the next one
    #: while the clients work on theirs (a command acts one tick later; runs still repeat)
    pipelined: bool = False
    #: lockstep only: once participants were seen, step on when none is left and none is
    #: expected (a run whose whole team has gone goes on to its end; a bare server waits)
    step_without_participants: bool = False
    queue_limit: int = 1024
    max_message_size: int = c.MAX_MESSAGE_SIZE
    #: stop reading from a client while this many replies wait unsent
    max_replies_waiting: int = 4096
    # -- limits against hostile or broken clients (see docs/player.md) --
    #: a client whose queued output exceeds this many bytes is disconnected (0 = no limit)
    output_limit_bytes: int = 32 << 20
    #: messages handled per client per loop turn; the rest wait for the next turn
    input_budget: int = 64
    #: replace rules a connection may add (more are NACKed)
    max_rules: int = 64
    #: connections open at once over every port (more are refused at accept); None = the
    #: default cap for the server's endpoints (`connection_cap`)
    max_connections: int | None = None
    #: a frame not completed within this many seconds closes its connection (0 = never)
    frame_timeout_s: float = 10.0
    #: simulated seconds without a message from the client that last commanded a robot's
    #: motion before the robot is stopped (0 = no watchdog)
    watchdog_s: float = 2.0


CONNECTIONS_FLOOR = 64
CONNECTIONS_PER_ENDPOINT = 4


def connection_cap(config: CoreConfig, endpoints: int) -> int:
    """Connections open at once over every port: the configured cap, or by default
    `CONNECTIONS_PER_ENDPOINT` for each endpoint (a robot's driving client, an observer, a
    print tool, a viewer), never fewer than `CONNECTIONS_FLOOR`."""
    if config.max_connections is not None:
        return config.max_connections
    return max(CONNECTIONS_FLOOR, CONNECTIONS_PER_ENDPOINT * endpoints)


@dataclass
class SessionCounters:
    messages_in: int = 0
    requests: int = 0
    commands: int = 0
    bad_messages: int = 0
    replies: int = 0
    nacks: int = 0
    rounds: int = 0
    #: turns that ended with the client's messages still waiting (its budget ran out)
    budget_exhausted: int = 0


@dataclass(eq=False)
class Session:
    """One TCP connection: its subscriptions, data mode, rules, queue and round state."""

    id: int
    endpoint: Endpoint
    decoder: Decoder
    queue: OutQueue
    peer: str = ""
    mode: int = c.PLAYER_DATAMODE_PUSH
    subs: dict[tuple[int, int], Driver] = field(default_factory=dict)
    rules: list[pm.AddReplaceRuleReq] = field(default_factory=list)
    round_pending: bool = False
    last_round: int = -1
    lockstep_override: bool | None = None
    demoted: bool = False
    counted_as_participant: bool = False
    #: subscribed to a live device (its DATA is read when each round goes out)
    has_live: bool = False
    stalled_since: float | None = None
    closing: str | None = None
    #: messages left in the decoder when the client's budget for a loop turn ran out
    backlog: bool = False
    counters: SessionCounters = field(default_factory=SessionCounters)
    # what the rules say, per DATA key and per device (cleared when rules or subs change)
    rule_of: dict[DataKey, int] = field(default_factory=dict)
    ignored: dict[tuple[int, int], bool] = field(default_factory=dict)
    # the last round built: (data version, its bytes with the SYNCH, or None when empty)
    built: tuple[tuple[float, int], bytes | None] | None = None
    # the devices a PULL round reads, in order: subscribed, neither live nor declined
    reads: tuple[tuple[tuple[int, int], Driver], ...] | None = None
    # a lockstep round published while this participant had not asked for it: (its
    # number, its bytes as published); sent when it asks
    owed: tuple[int, bytes] | None = None

    def forget_plan(self) -> None:
        """Subscriptions or rules changed: what was worked out from them no longer holds."""
        self.rule_of.clear()
        self.ignored.clear()
        self.built = None
        self.reads = None
        self.owed = None

    def round_reads(self, ignored: Callable[[Session, tuple[int, int]], bool],
                    ) -> tuple[tuple[tuple[int, int], Driver], ...]:
        """The devices a PULL round reads, in order: subscribed, neither live (read when
        the round goes out) nor declined by the client's rules (``ignored``)."""
        if self.reads is None:
            self.reads = tuple((key, d) for key, d in self.subs.items()
                               if not d.live and not (self.rules and ignored(self, key)))
        return self.reads

    @property
    def wants_input(self) -> bool:
        return self.closing is None

    def __hash__(self) -> int:
        return self.id


@dataclass
class CoreCounters:
    sessions_opened: int = 0
    sessions_closed_bad_input: int = 0
    bad_messages: int = 0
    rounds_published: int = 0
    demoted: int = 0
    commands_refused: int = 0
    internal_errors: int = 0
    driver_errors: int = 0
    closed_output_limit: int = 0
    rules_refused: int = 0
