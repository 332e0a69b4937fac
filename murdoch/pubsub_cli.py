"""`murdoch listen` and `murdoch announce`: the bus from a terminal (loopback multicast by
default, or Zenoh with `--transport zenoh`)."""

from __future__ import annotations

import json
import math
import os
import random
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import click

from murdoch.auction.messages import AuctionEvent, Outcome, TaskSpec
from murdoch.auth import TeamKey
from murdoch.endpoint import EndpointOptions
from murdoch.multicast import DEFAULT_GROUP, DEFAULT_PORT, MulticastConfig
from murdoch.node import Node
from murdoch.subjects import SubjectError, matches, subject_set
from murdoch.transport_choice import TRANSPORTS, TransportChoice, open_transport
from murdoch.user_agent import RandomizedBackoff
from murdoch.wire import Codec, Frame, WireError
from murdoch.zenoh_transport import DEFAULT_ENDPOINT, ZenohConfig, ZenohUnavailable

KEY_ENV = "MURDOCH_TEAM_KEY"


def _key(value: str | None) -> TeamKey | None:
    value = value or os.environ.get(KEY_ENV)
    try:
        return TeamKey(value) if value else None
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--key") from None


def _config(group: str, port: int, reply_lane: bool = False) -> MulticastConfig:
    try:
        return MulticastConfig(group, port, reply_lane=reply_lane)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--group/--port") from None


def _open(sender: str, clock: Any, net: dict[str, Any]) -> Any:
    """The transport the network options ask for (clear errors, no traceback)."""
    if net["transport"] == "zenoh":
        try:
            zenoh = ZenohConfig(endpoint=net["zenoh_endpoint"], hub=net["zenoh_hub"])
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--zenoh-endpoint") from None
        choice = TransportChoice("zenoh", zenoh=zenoh)
    else:
        choice = TransportChoice(
            "multicast", multicast=_config(net["group"], net["port"], net["reply_lane"]))
    try:
        return open_transport(choice, sender, clock, EndpointOptions(key=_key(net["key"])))
    except (ZenohUnavailable, OSError) as exc:
        raise click.ClickException(str(exc)) from None


def _where(transport: Any, net: dict[str, Any]) -> str:
    if net["transport"] == "zenoh":
        role = "as the hub on" if net["zenoh_hub"] else "through the hub at"
        return f"zenoh {role} {net['zenoh_endpoint']}"
    lanes = (f" and replies on {transport.config.replies_group}:{net['port']}"
             if net["reply_lane"] else "")
    return f"{net['group']}:{net['port']}{lanes} (loopback)"


def _subjects(value: str | None) -> frozenset[str] | None:
    if value is None:
        return None
    try:
        return subject_set(value)
    except SubjectError as exc:
        raise click.BadParameter(str(exc)) from None


def frame_problem(codec: Codec, frame: Frame) -> WireError | None:
    """Why the body of `frame` is not a valid message of its kind (the same check every
    receiver makes before delivering it); None when it is valid or of a kind `codec` does
    not know (a listener shows those undecoded)."""
    if not codec.knows(frame.kind):
        return None
    try:
        codec.message_from(frame.kind, frame.body)
    except WireError as exc:
        return exc
    return None


def _plain(value: Any) -> Any:
    """`value` with non-finite numbers (a JSON decoder reads 1e999 as infinity) written as
    strings, so that every output line is strict JSON."""
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _format_frame(now: float, frame: Frame, size: int, problem: WireError | None) -> str:
    fields = " ".join(
        f"{k}={json.dumps(_plain(v), separators=(',', ':'))}" for k, v in frame.body.items())
    subjects = ",".join(sorted(frame.subjects)) or "-"
    line = f"{now:10.3f} {frame.sender}#{frame.seq} {frame.kind:<9} [{subjects}] {size}B {fields}"
    return line if problem is None else f"{line} INVALID {problem}"


def _network_options(func: Any) -> Any:
    func = click.option("--group", default=DEFAULT_GROUP, show_default=True)(func)
    func = click.option("--port", type=int, default=DEFAULT_PORT, show_default=True)(func)
    func = click.option(
        "--key", default=None, help=f"Shared team key (default: ${KEY_ENV} if set)."
    )(func)
    func = click.option(
        "--reply-lane", is_flag=True,
        help="Replies on a second group (the whole team must use it).",
    )(func)
    func = click.option(
        "--transport", type=click.Choice(TRANSPORTS), default="multicast", show_default=True,
        help="UDP multicast, or Zenoh through a hub (pip install 'murdoch[zenoh]').",
    )(func)
    func = click.option(
        "--zenoh-endpoint", default=DEFAULT_ENDPOINT, show_default=True,
        help="--transport zenoh: the hub's tcp/127.0.0.1:PORT.",
    )(func)
    func = click.option(
        "--zenoh-hub", is_flag=True,
        help="--transport zenoh: be the hub (listen on the endpoint) rather than a client.",
    )(func)
    return func


@contextmanager
def _ctrl_c_stops() -> Iterator[threading.Event]:
    """Ctrl-C (SIGINT) sets the event the command's loop watches, instead of raising
    KeyboardInterrupt wherever the main thread happens to be: an exception inside a lock's
    wait could leave the lock held, and a transport's own threads (Zenoh's callbacks) would
    then wait on it for ever and keep `close()` from returning."""
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = signal.signal(signal.SIGINT, lambda _signo, _frame: stop.set())
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, previous)


@click.command()
@click.option(
    "--subjects", default=None, help="Show only messages these subjects would receive (a,b,c)."
)
@click.option("--duration", type=float, default=None, help="Stop after this many seconds.")
@click.option("--count", type=int, default=None, help="Stop after this many messages.")
@click.option("--json", "as_json", is_flag=True, help="One JSON object per message.")
@_network_options
def listen(
    subjects: str | None,
    duration: float | None,
    count: int | None,
    as_json: bool,
    **net: Any,
) -> None:
    """Print live MURDOCH traffic with decoded fields."""
    wanted = _subjects(subjects)
    clock = time.monotonic
    start = clock()
    sender = f"listen-{os.getpid()}"
    transport = _open(sender, clock, net)
    codec = transport.codec
    shown = 0
    invalid: dict[str, int] = {}

    def show(frame: Frame, size: int) -> None:
        nonlocal shown
        problem = frame_problem(codec, frame)
        if problem is not None:
            invalid[problem.reason] = invalid.get(problem.reason, 0) + 1
        if wanted is not None and not matches(frame.subjects, wanted):
            return
        shown += 1
        if as_json:
            record = {
                "t": round(clock() - start, 6),
                "sender": frame.sender,
                "seq": frame.seq,
                "kind": frame.kind,
                "subjects": sorted(frame.subjects),
                "bytes": size,
                "fields": _plain(dict(frame.body)),
            }
            if problem is not None:
                record["invalid"] = str(problem)
            click.echo(json.dumps(record, allow_nan=False))
        else:
            click.echo(_format_frame(clock() - start, frame, size, problem))
        sys.stdout.flush()

    transport.core.frame_tap = show
    click.echo(f"listening on {_where(transport, net)}", err=True)
    try:
        with _ctrl_c_stops() as stop:
            while not stop.is_set() and (duration is None or clock() - start < duration) and (
                count is None or shown < count
            ):
                transport.poll(timeout_s=0.1)
    finally:
        transport.close()
    dropped = transport.counters.dropped
    bad = {k: v for k, v in dropped.items() if k != "unmatched"}
    if invalid:
        click.echo(f"invalid (shown flagged, rejected by receivers): {json.dumps(invalid)}",
                   err=True)
    if bad:
        click.echo(f"dropped: {json.dumps(bad)}", err=True)


def _parse_params(items: tuple[str, ...]) -> dict[str, Any]:
    params: dict[str, Any] = {}
    for item in items:
        name, sep, raw = item.partition("=")
        if not sep or not name:
            raise click.BadParameter(f"{item!r} is not NAME=VALUE")
        try:
            params[name] = json.loads(raw)
        except json.JSONDecodeError:
            params[name] = raw
    return params


@click.command()
@click.argument("name")
@click.option("--subjects", required=True, help="Resources the task needs (a,b,c).")
@click.option("--duration", type=float, default=0.0, show_default=True, help="Expected seconds.")
@click.option("--param", "params", multiple=True, help="NAME=VALUE task parameter (repeatable).")
@click.option("--metric", "metrics", multiple=True, help="Metric name, or NAME=WEIGHT.")
@click.option("--bid-window", type=float, default=0.25, show_default=True)
@click.option("--renew-period", type=float, default=0.5, show_default=True)
@click.option("--contract-timeout", type=float, default=1.5, show_default=True)
@click.option("--patience", type=float, default=None, help="Reintroduce while unachievable.")
@click.option("--wait", type=float, default=600.0, show_default=True, help="Give up after.")
@click.option("--seed", type=int, default=None, help="Seed for the reintroduction backoff.")
@click.option("--quiet", is_flag=True, help="Print only the outcome.")
@_network_options
def announce(
    name: str,
    subjects: str,
    duration: float,
    params: tuple[str, ...],
    metrics: tuple[str, ...],
    bid_window: float,
    renew_period: float,
    contract_timeout: float,
    patience: float | None,
    wait: float,
    seed: int | None,
    quiet: bool,
    **net: Any,
) -> None:
    """Auction one task and print its outcome (exit 0 only when completed)."""
    metric_pairs = []
    for item in metrics:
        metric_name, _, weight = item.partition("=")
        try:
            metric_pairs.append((metric_name, float(weight) if weight else 1.0))
        except ValueError:
            raise click.BadParameter(f"{item!r} is not NAME or NAME=WEIGHT") from None
    try:
        spec = TaskSpec(
            name=name,
            subjects=_subjects(subjects) or frozenset(),
            params=_parse_params(params),
            duration_s=duration,
            metrics=tuple(metric_pairs),
            bid_window_s=bid_window,
            renew_period_s=renew_period,
            contract_timeout_s=contract_timeout,
            abandon_after_s=contract_timeout,
        )
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    clock = time.monotonic
    rng = random.Random(seed)
    sender = f"announce-{os.getpid()}-{rng.getrandbits(24):06x}"
    transport = _open(sender, clock, net)
    outcomes: list[Outcome] = []

    def show(event: AuctionEvent) -> None:
        if not quiet:
            detail = " ".join(f"{k}={v}" for k, v in event.detail.items())
            click.echo(f"{event.kind:<12} {event.task_id}#{event.attempt} {detail}")

    node = Node(
        transport,
        clock,
        agent_id=sender,
        on_outcome=outcomes.append,
        observer=show,
        backoff=RandomizedBackoff(rng, base_s=max(bid_window, 0.5), cap_s=30.0),
    )
    deadline = clock() + wait
    try:
        with _ctrl_c_stops() as stop:
            node.announce(spec, patience_s=patience)
            while not stop.is_set() and not outcomes and clock() < deadline:
                node.step(timeout_s=0.01)
    finally:
        node.close()
        transport.close()
    if not outcomes:
        click.echo(json.dumps({"task": name, "status": "unknown", "reason": "gave up waiting"}))
        sys.exit(3)
    outcome = outcomes[0]
    click.echo(
        json.dumps(
            {
                "task_id": outcome.task_id,
                "task": outcome.name,
                "status": outcome.status,
                "reason": outcome.reason,
                "winner": outcome.winner,
                "attempts": outcome.attempts,
            }
        )
    )
    sys.exit(0 if outcome.status == "completed" else 1)
