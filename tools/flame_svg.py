"""A small SVG flame graph of one thread from py-spy's raw (collapsed) output.

    py-spy record --subprocesses --threads --format raw -o run.txt -- murdoch run ...
    python tools/flame_svg.py run.txt --process "murdoch run" --thread player-server \\
        -o docs/figures/flame-serving-thread.svg [--min-share 0.005] [--title TEXT]
        [--drop importlib ...]

Keeps the samples whose process frame contains ``--process`` and whose thread frame
contains ``--thread``, drops the process and thread frames and the line numbers, and draws
every frame wider than ``--min-share`` of the samples (narrower ones are left out, which
keeps the file small). Hovering a box shows its function and share.
"""

from __future__ import annotations

import argparse
import html
import re
import zlib
from collections.abc import Iterable
from pathlib import Path

_LINE = re.compile(r":\d+\)$")
WIDTH = 1200.0
ROW = 16.0


def stacks(lines: Iterable[str], process: str, thread: str,
           drop: tuple[str, ...] = ()) -> dict[tuple[str, ...], int]:
    out: dict[tuple[str, ...], int] = {}
    for line in lines:
        stack, _, count = line.rstrip("\n").rpartition(" ")
        if not stack or not count.isdigit() or any(d in stack for d in drop):
            continue
        frames = stack.split(";")
        procs = [f for f in frames if f.startswith("process ")]
        threads = [f for f in frames if f.startswith("thread ")]
        if not procs or process not in procs[-1] or not threads or thread not in threads[0]:
            continue
        key = tuple(_LINE.sub(")", f) for f in frames
                    if not f.startswith(("process ", "thread ")))
        out[key] = out.get(key, 0) + int(count)
    return out


def tree(samples: dict[tuple[str, ...], int]) -> dict[str, object]:
    root: dict[str, object] = {"n": 0, "kids": {}}
    for key, n in samples.items():
        node = root
        node["n"] = int(node["n"]) + n  # type: ignore[call-overload]
        for f in key:
            kids: dict[str, dict[str, object]] = node["kids"]  # type: ignore[assignment]
            node = kids.setdefault(f, {"n": 0, "kids": {}})
            node["n"] = int(node["n"]) + n  # type: ignore[call-overload]
    return root


def svg(root: dict[str, object], title: str, min_share: float) -> str:
    total = max(int(root["n"]), 1)  # type: ignore[call-overload]
    boxes: list[str] = []
    depth_max = 0

    def walk(node: dict[str, object], x: float, depth: int) -> None:
        nonlocal depth_max
        kids: dict[str, dict[str, object]] = node["kids"]  # type: ignore[assignment]
        for name, kid in sorted(kids.items()):
            n = int(kid["n"])  # type: ignore[call-overload]
            if n / total < min_share:
                x += WIDTH * n / total
                continue
            w = WIDTH * n / total
            depth_max = max(depth_max, depth)
            label = html.escape(name)
            hue = 20 + zlib.crc32(name.split(" ")[0].encode()) % 40
            text = label if w > 60 else ""
            boxes.append(
                f'<g><title>{label} ({100 * n / total:.1f}%)</title>'
                f'<rect x="{x:.1f}" y="{{y{depth}}}" width="{w:.1f}" height="{ROW - 1}" '
                f'fill="hsl({hue},80%,60%)"/>'
                f'<text x="{x + 2:.1f}" y="{{t{depth}}}" font-size="11">'
                f'{text[: int(w / 6.5)]}</text></g>')
            walk(kid, x, depth + 1)
            x += w

    walk(root, 0.0, 0)
    height = (depth_max + 3) * ROW
    out = "\n".join(boxes)
    for d in range(depth_max + 1):  # the root at the bottom, as flame graphs are drawn
        y = height - (d + 2) * ROW
        out = out.replace(f"{{y{d}}}", f"{y:.0f}").replace(f"{{t{d}}}", f"{y + 12:.0f}")
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH:.0f}" '
            f'height="{height:.0f}" font-family="monospace">\n'
            f'<text x="4" y="12" font-size="12">{html.escape(title)} '
            f'({total} samples)</text>\n{out}\n</svg>\n')


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("raw", type=Path)
    ap.add_argument("--process", default="", help="a string of the process's command line")
    ap.add_argument("--thread", default="", help="a string of the thread's name")
    ap.add_argument("-o", "--out", type=Path, required=True)
    ap.add_argument("--min-share", type=float, default=0.005)
    ap.add_argument("--title", default="")
    ap.add_argument("--drop", action="append", default=[],
                    help="leave out the samples whose stack contains this (repeatable)")
    args = ap.parse_args()
    with args.raw.open() as f:
        samples = stacks(f, args.process, args.thread, tuple(args.drop))
    if not samples:
        raise SystemExit(f"{args.raw}: no samples of process {args.process!r} thread "
                         f"{args.thread!r}")
    args.out.write_text(svg(tree(samples), args.title or args.thread, args.min_share))
    print(f"{args.out}: {args.out.stat().st_size} bytes")


if __name__ == "__main__":
    main()
