"""Versioned JSON documents: atomic writes and checked reads (../shared/STYLE.md); and the
checked reading of other outside text: numbers in text fields, XML without DTDs."""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeAlias

from mound.errors import InputError

if TYPE_CHECKING:
    from xml.etree.ElementTree import Element

# A JSON value and a JSON object, as the documents' writers (to_doc) return them: mypy then
# refuses a value json.dumps cannot write (an array, a Path, a dataclass) where it is made.
JsonValue: TypeAlias = (None | bool | int | float | str | Sequence["JsonValue"]
             | Mapping[str, "JsonValue"])
JsonObject: TypeAlias = dict[str, JsonValue]


def _stage(path: Path, text: str | bytes) -> Path:
    """`text` (UTF-8) or bytes in a fresh temporary file beside `path` (a unique name:
    mkstemp)."""
    if path.is_dir():
        raise InputError(f"{path}: is a folder, not a file to write")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.name + ".tmp.", dir=path.parent)
    except OSError as e:
        raise InputError(f"{path}: cannot write ({e.strerror})") from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(text.encode("utf-8") if isinstance(text, str) else text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, new_file_mode())
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return Path(tmp)


def new_file_mode() -> int:
    """The mode a newly created file gets (0666 less the umask), for files staged with
    mkstemp (which makes them 0600)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextmanager
def staged_file(path: str | Path, suffix: str = "") -> Iterator[Path]:
    """For writers that need a path (GeoTIFFs through GDAL): yields a fresh temporary file
    beside `path`; when the block ends normally it gets the usual file mode and is renamed
    over `path`, otherwise it is removed."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, new_file_mode())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_atomic(path: str | Path, text: str) -> None:
    """Writes `text` to `path` through a temporary file in the same folder and a rename."""
    write_all_atomic([(path, text)])


def write_all_atomic(outputs: Sequence[tuple[str | Path, str | bytes]]) -> None:
    """Writes several files as one: every text is staged in a temporary file first, and
    only when all are staged are they renamed into place. A failure removes the staged
    files and any output this call had created, so a command that fails leaves nothing
    behind (files that existed before keep their old contents unless their rename ran)."""
    staged: list[tuple[Path, Path]] = []
    placed: list[Path] = []
    try:
        for path, text in outputs:
            staged.append((Path(path), _stage(Path(path), text)))
        for path, tmp in staged:
            existed = path.exists()
            try:
                os.replace(tmp, path)
            except OSError as e:
                raise InputError(f"{path}: cannot write ({e.strerror})") from None
            if not existed:
                placed.append(path)
    except BaseException:
        for _, tmp in staged:
            tmp.unlink(missing_ok=True)
        for path in placed:
            path.unlink(missing_ok=True)
        raise


def _reject_non_finite(value: Any, where: str) -> None:
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError(f"{where}: non-finite number {value}")
    if isinstance(value, dict):
        for k, v in value.items():
            _reject_non_finite(v, f"{where}.{k}" if where else k)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _reject_non_finite(v, f"{where}[{i}]")


def json_text(doc: Mapping[str, object]) -> str:
    """A document as the project writes JSON; NaN/Infinity are refused (they are not JSON)."""
    _reject_non_finite(doc, "")
    return json.dumps(doc, indent=1, allow_nan=False) + "\n"


def write_json(path: str | Path, doc: Mapping[str, object]) -> None:
    """Atomic JSON write; NaN/Infinity are refused (they are not JSON)."""
    write_atomic(path, json_text(doc))


# Bounds of what the readers accept (issue 14): text files up to 256 MiB (a sites file of
# a million sites is ~100 MB), integers up to 64 digits (10^400 overflowed float(); Python
# refuses to convert more than 4,300 digits at all), nesting as deep as the interpreter's
# recursion allows (about 1,000 levels; deeper is refused, not a crash).
MAX_TEXT_BYTES = 256 << 20
MAX_INT_DIGITS = 64


class _Refused(ValueError):
    pass


def read_text(path: str | Path, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """A UTF-8 text file; InputError naming the file if it cannot be read, is larger than
    `max_bytes` (an endless device, a runaway file) or is not UTF-8 (the line and offset of
    the first bad byte, never the file's contents)."""
    try:
        with open(path, "rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror})") from e
    if len(data) > max_bytes:
        raise InputError(f"{path}: larger than {max_bytes} bytes, the most this reader accepts")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise InputError(f"{path}:{line}: not UTF-8 text (byte 0x{data[e.start]:02x} at offset "
                         f"{e.start})") from None


def _parse_int(s: str) -> int:
    if len(s.lstrip("-")) > MAX_INT_DIGITS:
        raise _Refused(f"an integer of {len(s.lstrip('-'))} digits (at most {MAX_INT_DIGITS})")
    return int(s)


def _parse_float(s: str) -> float:
    v = float(s)
    if not math.isfinite(v):
        raise _Refused(f"{s[:24]} is beyond double precision")
    return v


def _parse_constant(s: str) -> NoReturn:
    raise _Refused(f"{s} is not valid JSON; values must be finite numbers")


def parse_json(text: str, path: str | Path) -> Any:
    """JSON text read from `path`; a syntax error names the file, line and column. NaN,
    Infinity, numbers beyond double precision, integers of more than 64 digits and nesting
    deeper than the interpreter's recursion limit are refused with an InputError."""
    try:
        return json.loads(text, parse_int=_parse_int, parse_float=_parse_float,
                          parse_constant=_parse_constant)
    except json.JSONDecodeError as e:
        raise InputError(f"{path}:{e.lineno}:{e.colno}: not valid JSON ({e.msg})") from None
    except _Refused as e:
        raise InputError(f"{path}: {e}") from None
    except RecursionError:
        raise InputError(f"{path}: nested too deeply (more than about "
                         f"{sys.getrecursionlimit()} levels)") from None


def require_number(obj: Mapping[str, Any], key: str, where: str, *, lo: float = -math.inf,
                   hi: float = math.inf, default: float | None = None) -> float:
    """obj[key] as a float: a finite number (not a bool) in [lo, hi]; `default` when the key
    is absent or null and a default is given. InputError naming `where.key` otherwise."""
    v = obj.get(key)
    if v is None and default is not None:
        return default
    return finite_number(v, f"{where}.{key}", lo=lo, hi=hi)


def optional_number(obj: Mapping[str, Any], key: str, where: str, *,
                    lo: float = -math.inf, hi: float = math.inf) -> float | None:
    """obj[key] as require_number reads it, or None when the key is absent or null."""
    v = obj.get(key)
    return None if v is None else finite_number(v, f"{where}.{key}", lo=lo, hi=hi)


def require_string(obj: Mapping[str, Any], key: str, where: str,
                   default: str | None = None) -> str:
    """obj[key] as a string; `default` when the key is absent and a default is given.
    InputError naming `where.key` otherwise."""
    v = obj.get(key, default)
    if not isinstance(v, str):
        raise InputError(f"{where}.{key}: expected a string, got {short_repr(v)}")
    return v


def require_count(obj: Mapping[str, Any], key: str, where: str, *, hi: float = 1e9) -> int:
    """obj[key] as a whole number in [0, hi] (a count); InputError naming `where.key`
    otherwise."""
    v = require_number(obj, key, where, lo=0, hi=hi)
    if v != int(v):
        raise InputError(f"{where}.{key}: expected a whole number, got {v:g}")
    return int(v)


def list_member(obj: Mapping[str, Any], key: str, where: str) -> list[Any]:
    """obj[key]: a list ([] when the key is absent); InputError naming `where.key`
    otherwise."""
    v = obj.get(key, [])
    if not isinstance(v, list):
        raise InputError(f"{where}.{key}: expected a list, got {short_repr(v)}")
    return v


def id_list(obj: Mapping[str, Any], key: str, where: str) -> list[str]:
    """obj[key]: a list of ids (require_id each; [] when the key is absent)."""
    return [require_id(x, f"{where}.{key}[{k}]")
            for k, x in enumerate(list_member(obj, key, where))]


def string_list(obj: Mapping[str, Any], key: str, where: str) -> list[str]:
    """obj[key]: a list of strings ([] when the key is absent); InputError naming the
    member otherwise."""
    v = list_member(obj, key, where)
    for k, x in enumerate(v):
        if not isinstance(x, str):
            raise InputError(f"{where}.{key}[{k}]: expected a string, got {short_repr(x)}")
    return v


def optional_string(obj: Mapping[str, Any], key: str, where: str) -> str | None:
    """obj[key] as a string, or None when the key is absent or null."""
    return None if obj.get(key) is None else require_string(obj, key, where)


def optional_number_list(obj: Mapping[str, Any], key: str, where: str,
                         size: int | None = None) -> tuple[float, ...] | None:
    """obj[key] as number_list reads it, or None when the key is absent or null."""
    v = obj.get(key)
    return None if v is None else number_list(v, f"{where}.{key}", size)


def optional_object(obj: Mapping[str, Any], key: str, where: str) -> Mapping[str, Any] | None:
    """obj[key]: an object, or None when the key is absent or null; InputError naming
    `where.key` otherwise."""
    v = obj.get(key)
    if v is not None and not isinstance(v, dict):
        raise InputError(f"{where}.{key}: expected an object, got {short_repr(v)}")
    return v


def require_choice(value: Any, choices: Sequence[str], where: str) -> str:
    """value if it is one of `choices`, else InputError naming `where`."""
    if value not in choices:
        said = " or ".join(choices) if len(choices) == 2 else "one of " + ", ".join(choices)
        raise InputError(f"{where}: expected {said}, got {short_repr(value)}")
    return str(value)


def number_text(text: str, where: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """A number written as text in a file's field (XML, CSV) as a float in [lo, hi], else
    InputError naming `where` (the file, line and field)."""
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{where}: expected a number, got {text[:40]!r}") from None
    if not (math.isfinite(v) and lo <= v <= hi):
        raise InputError(f"{where}: {v:g} outside {lo:g}..{hi:g}")
    return v


def finite_number(v: Any, where: str, *, lo: float = -math.inf, hi: float = math.inf,
                  expected: str = "a number") -> float:
    """v as a float: a finite number (not a bool) in [lo, hi], else InputError naming
    `where` (an integer beyond double precision included)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise InputError(f"{where}: expected {expected}, got {short_repr(v)}")
    try:
        f = float(v)
    except OverflowError:
        raise InputError(f"{where}: {short_repr(v)} is beyond double precision") from None
    if not math.isfinite(f) or not lo <= f <= hi:
        raise InputError(f"{where}: must be a number in [{lo:g}, {hi:g}], got {f:g}")
    return f


def as_object(doc: object, where: str) -> Mapping[str, Any]:
    """doc as a JSON object; InputError naming `where` otherwise."""
    if not isinstance(doc, dict):
        raise InputError(f"{where}: expected an object, got {short_repr(doc)}")
    return doc


def number_map(v: object, where: str, *, lo: float = -math.inf) -> dict[str, float]:
    """A JSON object of finite numbers (>= lo) by name; InputError naming `where.name`."""
    return {str(k): finite_number(x, f"{where}.{k}", lo=lo) for k, x in as_object(v, where).items()}


def renamed(doc: Mapping[str, Any], new: str, old: str, where: str) -> Mapping[str, Any]:
    """doc with a member's old name read as its new one (files written before a rename);
    InputError when both are given and differ. Never silently ignored: an unknown member
    is, so a file's old name would otherwise leave the new one at its default."""
    if old not in doc:
        return doc
    if new in doc and doc[new] != doc[old]:
        raise InputError(f"{where}: {new} and its old name {old} differ")
    return {new: doc[old], **{k: v for k, v in doc.items() if k != old}}


def xy_metres(v: object, where: str) -> tuple[float, float]:
    """[x, y] (metres; a third member, a height, is left) as two finite numbers."""
    if not isinstance(v, list) or len(v) < 2:
        raise InputError(f"{where}: expected [x, y] in metres, got {short_repr(v)}")
    return finite_number(v[0], f"{where}[0]"), finite_number(v[1], f"{where}[1]")


def number_list(v: object, where: str, size: int | None = None) -> tuple[float, ...]:
    """A list of finite numbers (`size` of them when given)."""
    if not isinstance(v, list) or (size is not None and len(v) != size):
        raise InputError(f"{where}: expected a list of {size or 'some'} numbers, "
                         f"got {short_repr(v)}")
    return tuple(finite_number(x, f"{where}[{k}]") for k, x in enumerate(v))


def require_id(value: Any, where: str) -> str:
    """An identifier: a non-empty string of at most 256 characters, no control characters."""
    if not isinstance(value, str) or not value:
        raise InputError(f"{where}: expected a non-empty string id, got {short_repr(value)}")
    if len(value) > 256 or any(ord(c) < 32 or ord(c) == 127 for c in value):
        raise InputError(f"{where}: an id has at most 256 characters and no control characters")
    return value


def short_repr(v: Any) -> str:
    """repr of a value for a one-line message, cut to 40 characters."""
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10**40:
        return f"an integer of about {int(v.bit_length() * 0.30103) + 1} digits"
    if isinstance(v, list | dict):
        return f"a {'list' if isinstance(v, list) else 'object'} of {len(v)} entries"
    r = repr(v)
    return r if len(r) <= 40 else r[:37] + "..."


def load_json(path: str | Path) -> Any:
    """A JSON file's value, whatever its top level (a GeoJSON, a document of any schema);
    InputError naming the file on any defect (read_text, parse_json)."""
    return parse_json(read_text(path), path)


def read_json(path: str | Path, schema: str, max_version: int) -> dict[str, Any]:
    """Reads a `schema` document of version 1..max_version; InputError on any defect."""
    return check_doc(load_json(path), path, schema, max_version)


def check_doc(doc: Any, path: str | Path, schema: str, max_version: int) -> dict[str, Any]:
    """`doc` (parsed from `path`) if it is a `schema` document of version 1..max_version;
    InputError otherwise."""
    if not isinstance(doc, dict):
        raise InputError(f"{path}: top level must be an object")
    if doc.get("schema") != schema:
        raise InputError(f"schema: expected {schema!r}, got {doc.get('schema')!r} in {path}")
    version = doc.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= max_version:
        raise InputError(f"version: unsupported {schema} version {version!r} in {path}")
    return doc


def parse_xml(data: bytes, where: str) -> Element:
    """The XML tree of `data`; no DTD, entities or external references (defusedxml), else
    InputError naming `where`."""
    import defusedxml.ElementTree as ET
    from defusedxml import DefusedXmlException

    try:
        return ET.fromstring(data, forbid_dtd=True)
    except LookupError as e:  # an encoding Python does not know (x-unknown, base64)
        raise InputError(f"{where}: the XML declares an encoding that cannot be read "
                         f"({' '.join(str(e).split())[:80]})") from None
    except (DefusedXmlException, ET.ParseError, ValueError) as e:
        raise InputError(f"{where}: not well-formed XML without a DTD "
                         f"({' '.join(str(e).split())[:100]})") from None
