"""Subject matching with hundreds of subscriptions: the posting-set index against a scan.

A MURDOCH receiver decides, from each datagram's header, which of its subscriptions hold all
of the datagram's subjects. With a hundred robots sharing a process (or one listener holding
a subscription per robot and per open negotiation), that is hundreds of subscriptions per
receiver. This measures, per message, `SubjectIndex.match` (intersect the posting sets of
the message's subjects) against the linear scan it replaces (test every subscription with
``message <= subscription``), on the same messages, alternating the two, and checks that
both give the same subscriptions.

The workload is a team's: each subscription holds a few resource subjects out of a small
vocabulary, ``idle`` for most, and one negotiation subject of its own (``task.<n>``);
messages are announcements (a few resource subjects, plus ``idle``) and negotiation
traffic (one ``task.<n>`` subject). Prints, per subscription count and message kind, the
mean number of subscriptions a message reaches, the median ns per message of each way and
the ratio scan/index, then one summary line. The index's cost follows the number of
holders (an announcement to `idle` robots reaches most of them), the scan's the number of
subscriptions.
"""

from __future__ import annotations

import argparse
import random
import statistics
import time

from murdoch.subjects import SubjectIndex, SubjectSet

RESOURCES = ["camera", "laser", "sonar", "bumper", "gripper", "mobile", "ptz", "fiducial",
             "overhead-camera", "have-puck", "blobfinder", "power"]


def workload(n_subs: int, n_messages: int, rng: random.Random
             ) -> tuple[dict[int, SubjectSet], list[SubjectSet]]:
    subs: dict[int, SubjectSet] = {}
    for key in range(n_subs):
        subjects = set(rng.sample(RESOURCES, rng.randint(2, 6)))
        if rng.random() < 0.8:
            subjects.add("idle")
        subjects.add(f"task.{key}")
        subs[key] = frozenset(subjects)
    messages: list[SubjectSet] = []
    for _ in range(n_messages):
        if rng.random() < 0.3:
            messages.append(frozenset({*rng.sample(RESOURCES, rng.randint(1, 3)), "idle"}))
        else:
            messages.append(frozenset({f"task.{rng.randrange(n_subs)}"}))
    return subs, messages


def scan(subs: dict[int, SubjectSet], message: SubjectSet) -> list[int]:
    return [k for k, s in subs.items() if message <= s]


def timed(fn: object, messages: list[SubjectSet]) -> float:
    start = time.perf_counter_ns()
    for message in messages:
        fn(message)  # type: ignore[operator]
    return (time.perf_counter_ns() - start) / len(messages)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--subscriptions", default="10,100,300,1000",
                        help="comma-separated subscription counts")
    parser.add_argument("--messages", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--seed", type=int, default=19)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    summary = []
    for n in (int(x) for x in args.subscriptions.split(",")):
        subs, messages = workload(n, args.messages, rng)
        index = SubjectIndex()
        for key, subjects in subs.items():
            index.set(key, subjects)
        for message in messages[:200]:
            assert index.match(message) == sorted(scan(subs, message)), message
        kinds = {
            "negotiation": [m for m in messages if "idle" not in m],
            "announce": [m for m in messages if "idle" in m],
        }
        for kind, batch in kinds.items():
            index_ns: list[float] = []
            scan_ns: list[float] = []
            for _ in range(args.rounds):  # alternate baseline and new on the same messages
                scan_ns.append(timed(lambda m, s=subs: scan(s, m), batch))
                index_ns.append(timed(index.match, batch))
            i_med, s_med = statistics.median(index_ns), statistics.median(scan_ns)
            ratio = s_med / i_med
            holders = statistics.mean(len(index.match(m)) for m in batch)
            print(f"subscriptions={n:<5} {kind:<11} holders_mean={holders:7.1f} "
                  f"index_ns_per_msg_median={i_med:8.0f} scan_ns_per_msg_median={s_med:8.0f} "
                  f"scan/index={ratio:6.1f}", flush=True)
            summary.append(f"{n}/{kind}:{ratio:.1f}x")
    print("subject_matching scan/index " + " ".join(summary))


if __name__ == "__main__":
    main()
