"""Reading YAML nobody vouched for (configs, batch files, a run folder's config).

One reader for every YAML file the package takes from a user:

* **the file** (:func:`read_file`): a regular file only (FIFOs, devices such
  as ``/dev/zero``, sockets and directories are refused from ``os.stat``
  before anything is opened; the file is opened with ``O_NONBLOCK`` and
  checked again), at most :data:`MAX_BYTES` bytes (at most that many plus
  one are ever read), UTF-8 (a leading byte-order mark is dropped), no NUL;
* **the YAML** (:func:`load`): built from libyaml's event stream by this
  module, not by PyYAML's constructor, so that nothing recurses, nothing
  executes and every limit is checked while reading:

  - no key twice in a mapping, at any level (``mechanism`` included);
  - at most :data:`MAX_DEPTH` levels of nesting, :data:`MAX_ALIASES` aliases,
    and :data:`MAX_NODES` nodes *after* expanding aliases (a "billion
    laughs" bomb is refused after reading its anchors, never expanded);
    an alias gives a copy of its anchor's value, never a shared object;
  - one document; only the standard tags ``!!str``, ``!!int``, ``!!float``,
    ``!!bool``, ``!!null``, ``!!map``, ``!!seq`` (no ``!!python/...``,
    ``!!binary``, ``!!timestamp``, ``!!set``);
  - plain scalars are read by the YAML 1.2 core schema, not YAML 1.1's:
    ``true``/``false`` (any case of the first letter, or all capitals) are
    booleans; ``yes``, ``no``, ``on``, ``off``, ``y``, ``n`` are strings;
    ``1:30`` is the string "1:30", not 90; ``012`` is twelve, ``0o12``
    octal ten, ``0x1f`` hexadecimal; ``1e-3`` is a number (YAML 1.1 read it
    as a string); ``1_000`` and dates stay strings.  So where a number is
    expected, ``1:30`` or ``yes`` is a mistake (reported), never a number;
  - no lone surrogate anywhere, no control character (other than tab, line
    feed and carriage return in values) in a key or value.

Every problem raises :class:`~optdesign.config.reader.ConfigError` naming the
file, the key path and the line.  :func:`dump` writes YAML that :func:`load`
reads back to the same values (strings that look like numbers are quoted).
"""
from __future__ import annotations

import os
import re
import stat
from typing import Any

import yaml

from .reader import ConfigError, join, shorten

__all__ = ["MAX_BYTES", "MAX_NODES", "MAX_ALIASES", "MAX_DEPTH", "read_file", "load", "load_file", "dump"]

#: largest YAML file read (bytes)
MAX_BYTES = 1_000_000
#: most nodes (scalars, mappings, sequences) of a document, aliases expanded
MAX_NODES = 200_000
#: most aliases (``*name``) in a document
MAX_ALIASES = 1_000
#: deepest nesting of mappings and sequences
MAX_DEPTH = 64

_Parser = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

# ---------------------------------------------------------------------- YAML 1.2 core schema
_NULL = re.compile(r"^(?:~|null|Null|NULL|)$")
_BOOL = {"true": True, "True": True, "TRUE": True, "false": False, "False": False, "FALSE": False}
_INT10 = re.compile(r"^[-+]?[0-9]+$")
_INT8 = re.compile(r"^0o[0-7]+$")
_INT16 = re.compile(r"^0x[0-9a-fA-F]+$")
_FLOAT = re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$")
_INF = re.compile(r"^[-+]?\.(?:inf|Inf|INF)$")
_NAN = re.compile(r"^\.(?:nan|NaN|NAN)$")
#: digits beyond which an integer literal is refused (Python's int/str conversion limit)
_MAX_DIGITS = 4000
#: control characters refused in keys (all) and values (all but tab, LF, CR)
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
_CONTROL_VALUE = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")
_SURROGATE = re.compile(r"[\ud800-\udfff]")

_TAG = "tag:yaml.org,2002:"
_SCALAR_TAGS = {_TAG + t for t in ("str", "int", "float", "bool", "null")}


class _Fail(Exception):
    def __init__(self, path: str, message: str):
        self.path, self.message = path, message


def _resolve_plain(text: str, path: str) -> Any:
    """A plain (unquoted) scalar by the YAML 1.2 core schema."""
    if _NULL.match(text):
        return None
    if text in _BOOL:
        return _BOOL[text]
    if _INT10.match(text):
        if len(text) > _MAX_DIGITS:
            raise _Fail(path, f"an integer literal of {len(text)} digits; expected a number of sensible size")
        return int(text, 10)
    if _INT8.match(text):
        return int(text[2:], 8) if len(text) <= _MAX_DIGITS else _too_long(text, path)
    if _INT16.match(text):
        return int(text[2:], 16) if len(text) <= _MAX_DIGITS else _too_long(text, path)
    if _FLOAT.match(text):
        if len(text) > _MAX_DIGITS:
            _too_long(text, path)
        return float(text)
    if _INF.match(text):
        return float("-inf") if text.startswith("-") else float("inf")
    if _NAN.match(text):
        return float("nan")
    return text


def _too_long(text: str, path: str):
    raise _Fail(path, f"a number literal of {len(text)} characters; expected a number of sensible size")


def _tagged(tag: str, text: str, path: str) -> Any:
    """A scalar with an explicit standard tag (``!!str 12``, ``!!float 1``)."""
    kind = tag[len(_TAG):]
    if kind == "str":
        return text
    value = _resolve_plain(text, path)
    wanted = {"int": int, "float": (int, float), "bool": bool, "null": type(None)}[kind]
    if isinstance(value, bool) and kind != "bool" or not isinstance(value, wanted):
        raise _Fail(path, f"!!{kind} {shorten(text)} is not a valid {kind}")
    return float(value) if kind == "float" else value


def _check_text(text: str, path: str, key: bool) -> None:
    if _SURROGATE.search(text):
        raise _Fail(path, f"{'key' if key else 'value'} {shorten(text)} holds a lone surrogate (not a Unicode character)")
    if (_CONTROL if key else _CONTROL_VALUE).search(text):
        raise _Fail(path, f"{'key' if key else 'value'} {shorten(text)} holds a control character")


# ---------------------------------------------------------------------- reading the file
def read_file(path: str | os.PathLike, limit: int = MAX_BYTES, what: str = "YAML file") -> str:
    """The text of a regular UTF-8 file of at most ``limit`` bytes (ConfigError otherwise)."""
    source = str(path)

    def fail(message: str):
        raise ConfigError(source, "", message)

    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        fail("file not found")
    except PermissionError:
        fail("cannot read file (permission denied)")
    except ValueError:          # a NUL in the path
        fail("not a valid file name")
    except OSError as exc:      # too long a name, a symlink loop
        fail(f"cannot read file ({exc.strerror or type(exc).__name__})")
    if stat.S_ISDIR(st.st_mode):
        fail(f"is a directory, expected a {what}")
    if not stat.S_ISREG(st.st_mode):
        fail(f"is {_file_kind(st.st_mode)}, expected a regular {what}")
    if st.st_size > limit:
        fail(f"file of {st.st_size:,} bytes; a {what} may have at most {limit:,} bytes")
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
                     | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        fail(f"cannot read file ({exc.strerror or type(exc).__name__})")
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):      # replaced since the stat
            fail(f"is not a regular file, expected a {what}")
        chunks, size = [], 0
        while size <= limit:
            try:
                b = os.read(fd, min(1 << 20, limit + 1 - size))
            except OSError as exc:
                fail(f"cannot read file ({exc.strerror or type(exc).__name__})")
            if not b:
                break
            chunks.append(b)
            size += len(b)
    finally:
        os.close(fd)
    if size > limit:
        fail(f"file of more than {limit:,} bytes; a {what} may have at most {limit:,} bytes")
    return decode(b"".join(chunks), source)


def _file_kind(mode: int) -> str:
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def decode(data: bytes, source: str) -> str:
    """UTF-8 text of a file's bytes (a leading byte-order mark dropped)."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(source, "", f"not a text file (expected UTF-8 YAML; invalid byte at offset {exc.start})") from None
    if text.startswith("\ufeff"):
        text = text[1:]
    if "\x00" in text:
        raise ConfigError(source, "", "not a text file (contains NUL bytes)")
    return text


# ---------------------------------------------------------------------- events -> plain data
_NOKEY = object()


class _Frame:
    """An open mapping or sequence while the events are read."""

    __slots__ = ("kind", "path", "items", "key", "merge", "merges", "lines", "anchor", "nodes")

    def __init__(self, kind: str, path: str, anchor, nodes_before: int):
        self.kind, self.path, self.anchor, self.nodes = kind, path, anchor, nodes_before
        self.items: Any = {} if kind == "map" else []
        self.key: Any = _NOKEY        # the key waiting for its value
        self.merge = False            # that key is a merge key (plain <<)
        self.merges: list[dict] = []
        self.lines: dict = {}         # key -> line of its first occurrence

    def child_path(self) -> str:
        if self.kind == "seq":
            return join(self.path, len(self.items))
        if self.key is _NOKEY:
            return self.path
        return join(self.path, self.key if isinstance(self.key, str) else shorten(self.key))

    def add(self, value: Any, line: int) -> None:
        if self.kind == "seq":
            self.items.append(value)
            return
        if self.key is _NOKEY:                      # a key
            if isinstance(value, (dict, list)):
                raise _Fail(self.path, f"a mapping or list as a key (line {line}); expected a string key")
            if isinstance(value, str):
                _check_text(value, join(self.path, value), key=True)
            if value in self.lines:
                raise _Fail(join(self.path, value if isinstance(value, str) else shorten(value)),
                            f"duplicate key (line {line}; first at line {self.lines[value]})")
            self.lines[value] = line
            self.key = value
            return
        key, self.key = self.key, _NOKEY
        if self.merge:
            self.merge = False
            merged = value if isinstance(value, list) else [value]
            if not all(isinstance(m, dict) for m in merged):
                raise _Fail(join(self.path, "<<"), "a merge key takes a mapping or a list of mappings")
            self.merges.extend(merged)
            return
        self.items[key] = value

    def value(self) -> Any:
        if self.kind == "map" and self.merges:
            merged: dict = {}
            for m in reversed(self.merges):          # earlier mappings take precedence
                merged.update(m)
            merged.update(self.items)                # and the mapping's own keys over all of them
            return merged
        return self.items


def load(text: str, source: str = "<string>") -> Any:
    """Plain data (dict, list, str, int, float, bool, None) of one YAML document;
    None for an empty one.  ConfigError on any problem (see the module docstring)."""
    try:
        parser = _Parser(text)
        try:
            return _consume(parser)
        finally:
            parser.dispose()
    except _Fail as exc:
        raise ConfigError(source, exc.path, exc.message) from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = exc.problem or exc.context or "invalid YAML"
        raise ConfigError(source, "", f"YAML syntax error{where}: {problem}") from None
    except yaml.YAMLError as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ConfigError(source, "", f"YAML could not be read ({shorten(first)})") from None
    except (RecursionError, MemoryError, ValueError, TypeError) as exc:
        raise ConfigError(source, "", f"YAML could not be read ({type(exc).__name__})") from None


def load_file(path: str | os.PathLike, what: str = "YAML file") -> tuple[Any, str]:
    """(data, text) of a YAML file, read and checked as the module docstring says."""
    text = read_file(path, what=what)
    return load(text, str(path)), text


def _copy(value: Any) -> Any:
    """A copy of plain loaded data (an alias gives a copy, never a shared
    object): dicts and lists copied, the scalars (immutable) kept; about
    three times faster than copy.deepcopy (no memo of shared objects: there
    are none in loaded data, every alias being a copy already)."""
    if type(value) is dict:
        return {k: _copy(v) for k, v in value.items()}
    if type(value) is list:
        return [_copy(v) for v in value]
    return value


def _consume(parser) -> Any:
    anchors: dict[str, tuple[Any, int]] = {}   # anchor -> (value, its number of nodes)
    stack: list[_Frame] = []
    nodes = aliases = docs = 0
    result: Any = None

    def put(value: Any, line: int) -> None:
        nonlocal result
        if stack:
            stack[-1].add(value, line)
        else:
            result = value

    def count(n: int, path: str, line: int) -> None:
        nonlocal nodes
        nodes += n
        if nodes > MAX_NODES:
            raise _Fail(path, f"more than {MAX_NODES:,} nodes, aliases expanded (line {line}); "
                              "expected a smaller file")

    while True:
        ev = parser.get_event()
        if isinstance(ev, yaml.StreamEndEvent):
            return result
        if isinstance(ev, (yaml.StreamStartEvent, yaml.DocumentEndEvent)):
            continue
        line = ev.start_mark.line + 1 if ev.start_mark is not None else 0
        if isinstance(ev, yaml.DocumentStartEvent):
            docs += 1
            if docs > 1:
                raise _Fail("", f"a second YAML document at line {line}; expected one document")
            continue
        path = stack[-1].child_path() if stack else ""
        in_key = bool(stack) and stack[-1].kind == "map" and stack[-1].key is _NOKEY
        if isinstance(ev, yaml.AliasEvent):
            if ev.anchor not in anchors:
                raise _Fail(path, f"alias *{shorten(ev.anchor)} of no anchor (line {line})")
            aliases += 1
            if aliases > MAX_ALIASES:
                raise _Fail(path, f"more than {MAX_ALIASES:,} aliases (line {line}); expected a plain file")
            value, size = anchors[ev.anchor]
            count(size, path, line)                  # refused before anything is copied
            put(_copy(value), line)
        elif isinstance(ev, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            kind = "map" if isinstance(ev, yaml.MappingStartEvent) else "seq"
            if ev.tag not in (None, "!", _TAG + kind):
                raise _Fail(path, f"unsupported YAML tag {shorten(ev.tag)} (line {line})")
            if in_key:
                raise _Fail(path, f"a mapping or list as a key (line {line}); expected a string key")
            if len(stack) >= MAX_DEPTH:
                raise _Fail(path, f"nested more than {MAX_DEPTH} levels deep (line {line})")
            count(1, path, line)
            stack.append(_Frame(kind, path, ev.anchor, nodes - 1))
        elif isinstance(ev, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            top = stack.pop()
            value = top.value()
            if top.anchor is not None:
                anchors[top.anchor] = (value, nodes - top.nodes)
            put(value, line)
        elif isinstance(ev, yaml.ScalarEvent):
            count(1, path, line)
            plain = ev.tag is None and bool(ev.implicit[0]) and not ev.style   # '' in libyaml, None in PyYAML
            if ev.tag is None or ev.tag == "!":
                value = _resolve_plain(ev.value, path) if plain else ev.value
            elif ev.tag in _SCALAR_TAGS:
                value = _tagged(ev.tag, ev.value, path)
            else:
                raise _Fail(path, f"unsupported YAML tag {shorten(ev.tag)} (line {line})")
            if in_key and plain and value == "<<":
                if "<<" in stack[-1].lines:
                    raise _Fail(join(stack[-1].path, "<<"), f"duplicate key (line {line})")
                stack[-1].lines["<<"] = line
                stack[-1].key, stack[-1].merge = "<<", True
                continue
            if isinstance(value, str) and not in_key:
                _check_text(value, path, key=False)
            if ev.anchor is not None:
                anchors[ev.anchor] = (value, 1)
            put(value, line)


# ---------------------------------------------------------------------- writing
class _Dumper(yaml.SafeDumper):
    """For the dumper's quoting decisions: YAML 1.1's implicit types (PyYAML's
    resolver) and those of :func:`load`'s schema, so that a string either
    would read as something else (``yes``, ``1:30``, ``1e3``, ``012``) is
    quoted; never an alias."""

    def ignore_aliases(self, data):
        return True


for _tag, _rx, _first in (
        ("bool", r"^(?:true|True|TRUE|false|False|FALSE)$", "tTfF"),
        ("int", r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$", "-+0123456789"),
        ("float", r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$",
         "-+0123456789."),
        ("null", r"^(?:~|null|Null|NULL|)$", ["~", "n", "N", ""])):
    _Dumper.add_implicit_resolver(_TAG + _tag, re.compile(_rx), list(_first))


def dump(data: Any, **kw) -> str:
    """YAML text of plain data that :func:`load` reads back to equal values."""
    return yaml.dump(data, Dumper=_Dumper, **kw)
