"""Which logs were written since the last tick: the kernel's notes (inotify), or "all of
them" where it cannot tell."""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import pytest

from experiments import log_writes
from experiments.log_writes import FolderWrites, parse_notes

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="inotify is Linux's")


def _note(mask: int, name: bytes = b"") -> bytes:
    padded = name + b"\0" * (-len(name) % 16 or (16 if name else 0))
    return struct.pack("iIII", 1, mask, 0, len(padded)) + padded


def test_notes_name_their_files_and_an_overflow_loses_them() -> None:
    buffer = _note(2, b"p1.events.jsonl") + _note(2, b"p2.auction.jsonl") + _note(2, b"p1.log")
    assert parse_notes(buffer) == ({"p1.events.jsonl", "p2.auction.jsonl", "p1.log"}, False)
    names, lost = parse_notes(_note(2, b"p1.events.jsonl") + _note(0x4000))
    assert names == {"p1.events.jsonl"} and lost


@linux
def test_a_write_by_another_process_is_known_when_its_write_has_returned(
        tmp_path: Path) -> None:
    (tmp_path / "p1.events.jsonl").write_text("")
    (tmp_path / "p2.events.jsonl").write_text("")
    watch = FolderWrites(tmp_path)
    try:
        assert watch.watching
        assert watch.written() is None  # the first look: whatever came before the watch
        assert watch.written() == set()  # nothing since
        subprocess.run([sys.executable, "-c",
                        f"open({str(tmp_path / 'p2.events.jsonl')!r}, 'a').write('{{}}\\n')"],
                       check=True, timeout=60)
        assert watch.written() == {"p2.events.jsonl"}
        assert watch.written() == set()
        with (tmp_path / "p1.events.jsonl").open("a") as f:
            f.write("{}\n")
            f.flush()
            assert watch.written() == {"p1.events.jsonl"}
            f.write("{}\n")
        (tmp_path / "p3.auction.jsonl").write_text("{}\n")  # a file new since the watch
        assert watch.written() == {"p1.events.jsonl", "p3.auction.jsonl"}
    finally:
        watch.close()
    assert watch.written() is None  # closed: every file may have been written


def test_without_inotify_every_look_says_all(tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(log_writes, "_libc", lambda: None)
    watch = FolderWrites(tmp_path)
    assert not watch.watching
    (tmp_path / "p1.events.jsonl").write_text("{}\n")
    assert watch.written() is None
    assert watch.written() is None


@linux
def test_a_folder_that_cannot_be_watched_says_all(tmp_path: Path) -> None:
    watch = FolderWrites(tmp_path / "missing")
    assert not watch.watching and watch.written() is None
