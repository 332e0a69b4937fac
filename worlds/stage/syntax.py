"""Stage world-file syntax: tokens, properties, entities, `include` and `define`.

The same syntax carries Player `.cfg` files. `parse_file` returns a `Document`: the global
properties, the definitions and the top-level entities, each remembering its file and line.
Nothing here knows what a key means.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from worlds.errors import WorldError

__all__ = ["Define", "Document", "Entity", "Prop", "StageError", "Where", "parse_file",
           "parse_text"]


@dataclass(frozen=True)
class Where:
    """A place in a file (line counted from 1)."""

    file: Path
    line: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}" if self.line else str(self.file)


class StageError(WorldError):
    """A Stage world or Player configuration file is malformed: file:line, expected, found."""

    def __init__(self, where: Where, expected: str, found: object) -> None:
        super().__init__(where.file, "", expected, found)
        self.where = where
        self.args = (f"{where}: expected {expected}, found {found}",)

    def __str__(self) -> str:
        return str(self.args[0])


Scalar = str | float


@dataclass(frozen=True)
class Prop:
    """A property `key value` or `key [v1 v2 ...]` (numbers as floats, strings as str)."""

    key: str
    values: tuple[Scalar, ...]
    bracketed: bool
    where: Where


@dataclass(frozen=True)
class Entity:
    """`kind ( properties and child entities )`."""

    kind: str
    props: tuple[Prop, ...]
    children: tuple[Entity, ...]
    where: Where


@dataclass(frozen=True)
class Define:
    """`define name base ( ... )`."""

    name: str
    base: str
    body: Entity


@dataclass(frozen=True)
class Document:
    props: tuple[Prop, ...]
    defines: dict[str, Define]
    entities: tuple[Entity, ...]
    files: tuple[Path, ...]


_TOKEN = re.compile(r"""
    (?P<space>[ \t\r\f\v]+) | (?P<newline>\n) | (?P<comment>\#[^\n]*)
  | (?P<string>"[^"\n]*")
  | (?P<number>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![A-Za-z_]))
  | (?P<word>[A-Za-z_][A-Za-z0-9_.:\-]*(?:\[\d+\])?)
  | (?P<punct>[()\[\]])
""", re.VERBOSE)


@dataclass(frozen=True)
class _Tok:
    kind: str  # "string", "number", "word", "punct", "end"
    text: str
    line: int


def _tokens(text: str, file: Path) -> list[_Tok]:
    out: list[_Tok] = []
    line = 1
    pos = 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise StageError(Where(file, line), "a word, number, string, ( ) or [ ]",
                             repr(text[pos:pos + 12].split("\n")[0]))
        kind = m.lastgroup or ""
        if kind == "newline":
            line += 1
        elif kind in ("string", "number", "word", "punct"):
            out.append(_Tok(kind, m.group(), line))
        pos = m.end()
    out.append(_Tok("end", "end of file", line))
    return out


def _describe(t: _Tok) -> str:
    return t.text if t.kind == "end" else repr(t.text)


class _Parser:
    def __init__(self, text: str, file: Path, defines: dict[str, Define],
                 seen: tuple[Path, ...]) -> None:
        self.file = file
        self.toks = _tokens(text, file)
        self.i = 0
        self.defines = defines
        self.seen = seen
        self.files: list[Path] = [file]

    def peek(self, k: int = 0) -> _Tok:
        return self.toks[min(self.i + k, len(self.toks) - 1)]

    def take(self) -> _Tok:
        t = self.peek()
        self.i += 1
        return t

    def where(self, t: _Tok) -> Where:
        return Where(self.file, t.line)

    def expect(self, kind: str, text: str | None, expected: str) -> _Tok:
        t = self.take()
        if t.kind != kind or (text is not None and t.text != text):
            raise StageError(self.where(t), expected, _describe(t))
        return t

    def define(self) -> None:
        name = self.expect("word", None, "a new kind's name after define")
        base = self.expect("word", None, f"a base kind after define {name.text}")
        body = self.entity(base)
        self.defines[name.text] = Define(name.text, base.text, body)

    def entity(self, head: _Tok) -> Entity:
        self.expect("punct", "(", f"( after {head.text}")
        props: list[Prop] = []
        children: list[Entity] = []
        while True:
            t = self.take()
            if t.kind == "punct" and t.text == ")":
                return Entity(head.text, tuple(props), tuple(children), self.where(head))
            if t.kind != "word":
                raise StageError(self.where(t), f"a key, a child entity or ) in {head.text}",
                                 _describe(t))
            if self.peek().kind == "punct" and self.peek().text == "(":
                children.append(self.entity(t))
            else:
                props.append(self.prop(t))

    def prop(self, key: _Tok) -> Prop:
        t = self.take()
        where = self.where(key)
        if t.kind == "punct" and t.text == "[":
            values: list[Scalar] = []
            while True:
                v = self.take()
                if v.kind == "punct" and v.text == "]":
                    return Prop(key.text, tuple(values), True, where)
                values.append(self.scalar(v, key.text))
        return Prop(key.text, (self.scalar(t, key.text),), False, where)

    def scalar(self, t: _Tok, key: str) -> Scalar:
        if t.kind == "number":
            return float(t.text)
        if t.kind == "string":
            return t.text[1:-1]
        raise StageError(self.where(t), f"a number, a quoted string or [ ... ] for {key}",
                         _describe(t))


def _run(text: str, file: Path, defines: dict[str, Define],
         seen: tuple[Path, ...]) -> tuple[list[Prop], list[Entity], list[Path]]:
    p = _Parser(text, file, defines, seen)
    # includes are read where they stand: their props/entities come before what follows
    props: list[Prop] = []
    entities: list[Entity] = []
    while p.peek().kind != "end":
        t = p.take()
        if t.kind != "word":
            raise StageError(p.where(t), "a key, an entity, include or define", _describe(t))
        if t.text == "include":
            s = p.expect("string", None, "a quoted file name after include")
            path = (file.parent / s.text[1:-1]).resolve()
            if path in seen:
                raise StageError(p.where(s), "an include that does not include itself", s.text)
            try:
                sub_text = path.read_text(encoding="utf-8")
            except OSError as exc:
                raise StageError(p.where(s), "an include file that can be read",
                                 f"{s.text} ({exc.strerror or exc})") from None
            sp, se, sf = _run(sub_text, path, defines, (*seen, path))
            props += sp
            entities += se
            p.files += sf
        elif t.text == "define":
            p.define()
        elif p.peek().kind == "punct" and p.peek().text == "(":
            entities.append(p.entity(t))
        else:
            props.append(p.prop(t))
    return props, entities, p.files


def parse_text(text: str, file: Path) -> Document:
    """Parse a world or configuration text (includes are found next to ``file``)."""
    defines: dict[str, Define] = {}
    props, entities, files = _run(text, file, defines, (file.resolve(),))
    return Document(tuple(props), defines, tuple(entities), tuple(files))


def parse_file(path: Path | str) -> Document:
    """Read and parse a file; a missing or unreadable file is a StageError naming it (line 0:
    no line)."""
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise StageError(Where(file, 0), "a readable text file",
                         getattr(exc, "strerror", None) or str(exc)) from None
    return parse_text(text, file)
