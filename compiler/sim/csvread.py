"""Streaming reader for delimited text measurement files (CSV, semicolon, tab, whitespace).

The file is read in blocks of whole lines (``BLOCK`` bytes), and each block is checked
and parsed with vectorised numpy: the number of fields per line comes from the
separator positions, the numbers from one ``np.loadtxt`` call (its C parser). Only when a block
is malformed is it re-read line by line, to name the line and the column. Memory is
therefore the columns themselves plus a few blocks: a 1e7-row file of four columns
needs ~320 MB of float64 and little more (see bench/bench_read_csv.py).

Columns of text (a closed-loop record's controller ``mode``) are found from the first data
rows (:data:`TEXT_SAMPLE`) and skipped by the parser, with one note naming them: a column is
text only when none of its sampled values reads as a number, so a numeric column with one bad
value still stops at that value's line and column.
"""

from __future__ import annotations

import io
import re

import numpy as np

from ..errors import PendcError
from .table import Table

BLOCK = 1 << 22  # bytes of text parsed at a time
TEXT_SAMPLE = 16  # data rows that decide which columns hold text
_KEY = r"[A-Za-z_][\w.\-]*"  # one word, so prose like '# Run 3 on rig B: ok' is not metadata
META_LINE = re.compile(rf"#\s*({_KEY})\s*:\s*(.*?)\s*$")
SEPARATORS = {",": ",", "comma": ",", ";": ";", "semicolon": ";", "\\t": "\t", "\t": "\t", "tab": "\t",
              "whitespace": None, "space": None, " ": None}
_BLANKS = b" \t\r\n"


def separator_from_name(name: str | None):
    """The separator an option names ('auto' -> ``...``, 'whitespace' -> None)."""
    if name in (None, "", "auto"):
        return ...
    if name in SEPARATORS:
        return SEPARATORS[name]
    if len(name) == 1 and name not in "0123456789.+-eE#":
        return name
    raise PendcError(f"--separator {name!r}: use one character, or comma, semicolon, tab, whitespace")


def detect_separator(header: str):
    """',' then ';' then tab if the header holds one, else runs of whitespace (None)."""
    for sep in (",", ";", "\t"):
        if sep in header:
            return sep
    return None


def read_csv_table(stream, source: str, separator=..., decimal=..., encoding: str = "utf-8") -> Table:
    """Read a delimited text file from binary ``stream`` (see the module docstring).

    Leading ``#`` lines and blank lines come before one header row; ``# key: value``
    comment lines become metadata. ``separator``: a character, None for whitespace,
    or ``...`` to detect it from the header. ``decimal``: '.' or ',' (as written by
    spreadsheets in many locales, with ';' or tab between fields), or ``...`` to take
    ',' when the separator is not a comma and the first data row has commas but no point.
    ``encoding`` decodes the comments and the header (the data rows are numbers).
    """
    meta, line_no, comments = {}, 0, False
    header = None
    while header is None:
        raw = stream.readline()
        line_no += 1
        if not raw:
            raise PendcError(f"{source}: no header row (only comments)" if comments else f"{source}: file is empty")
        if line_no == 1 and raw.startswith(b"\xef\xbb\xbf"):
            raw = raw[3:]
        text = _decode(raw, source, line_no, encoding).rstrip("\r\n")
        if text.startswith("#"):
            comments = True
            m = META_LINE.match(text)
            if m:
                meta[m.group(1)] = m.group(2)
        elif text.strip():
            header = text
    sep = detect_separator(header) if separator is ... else separator
    names = [n.strip() for n in (header.split(sep) if sep is not None else header.split())]
    if decimal == "," and sep == ",":
        raise PendcError(f"{source}: decimal commas need another field separator than ',' (--separator)")
    size = _remaining_bytes(stream)
    headerless = all(_is_number(n) for n in names)
    if headerless:  # the line is data: columns are numbered 1, 2, ... (--columns maps them)
        names = [str(k + 1) for k in range(len(names))]
        stream, size = _Prefixed(raw, stream), (size + len(raw) if size is not None else None)
        line_no -= 1
    _check_header(source, names, line_no)
    notes, text = [], {}
    if not headerless:  # a headerless file's first row is all numbers: no column is text
        stream, text = _text_columns(stream, names, sep, line_no + 1)
        if len(text) == len(names):
            name, (line, value) = next(iter(text.items()))
            raise PendcError(f"{source}: line {line}: no column holds numbers (column '{name}': {value!r})")
        if text:
            notes.append(f"{source}: ignoring text column(s) {', '.join(text)}")
    columns = _read_rows(stream, source, names, sep, line_no + 1, decimal, notes, size, text)
    return Table(columns=columns, meta=meta, source=source, first_line=line_no + 1, notes=tuple(notes),
                 headerless=headerless, text_columns=text)


def _text_columns(stream, names: list, sep, first: int):
    """``(stream, text)``: the stream with the sampled rows put back, and name -> (line, value)
    of the first value of each column that holds only text in the first :data:`TEXT_SAMPLE`
    data rows. A blank value is no evidence (an empty column stays numeric, and its error
    names it), nor is a decimal comma ('0,5' is a number written another way)."""
    sampled, raws, seen = 0, [], {}
    numeric = set()
    line = first - 1
    while sampled < TEXT_SAMPLE:
        raw = stream.readline()
        if not raw:
            break
        raws.append(raw)
        line += 1
        text = raw.decode("utf-8", errors="replace").rstrip("\r\n")
        fields = text.split(sep) if sep is not None else text.split()
        if text.startswith("#") or not text.strip() or len(fields) != len(names):
            continue  # malformed rows are the parser's to name
        sampled += 1
        for k, value in enumerate(fields):
            value = value.strip()
            if not value:
                continue
            if _is_number(value.replace(",", ".")):
                numeric.add(k)
            elif k not in seen:
                seen[k] = (line, value)
    text = {names[k]: seen[k] for k in sorted(seen) if k not in numeric}
    return (_Prefixed(b"".join(raws), stream) if raws else stream), text


class _Prefixed:
    """A binary stream with some bytes put back in front of it."""

    def __init__(self, prefix: bytes, stream):
        self.prefix, self.stream = prefix, stream

    def read(self, size: int) -> bytes:
        head, self.prefix = self.prefix, b""
        return head + self.stream.read(max(size - len(head), 1)) if head else self.stream.read(size)


def _decode(raw: bytes, source: str, line: int, encoding: str = "utf-8") -> str:
    try:
        return raw.decode(encoding)
    except UnicodeDecodeError as exc:
        hint = " (if it was saved as Latin-1 or Windows-1252, give --encoding cp1252)" if encoding == "utf-8" else ""
        name = "UTF-8" if encoding == "utf-8" else encoding
        raise PendcError(f"{source}: line {line}: not {name} text (byte 0x{raw[exc.start]:02x}){hint}") from None
    except LookupError:
        raise PendcError(f"--encoding {encoding!r}: unknown text encoding") from None


def _check_header(source: str, names: list, line: int) -> None:
    if any(not n for n in names):
        raise PendcError(f"{source}: line {line}: header has an empty column name")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise PendcError(f"{source}: line {line}: duplicate column name(s) {', '.join(dup)}")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _remaining_bytes(stream):
    """Bytes left in ``stream`` (a file or BytesIO), or None for a pipe."""
    try:
        import os

        return os.fstat(stream.fileno()).st_size - stream.tell()
    except (OSError, AttributeError, ValueError, io.UnsupportedOperation):
        pass
    try:
        return stream.getbuffer().nbytes - stream.tell()
    except (AttributeError, ValueError):
        return None


class _Columns:
    """Float64 columns filled block by block, allocated once from the file's size.

    Keeping each block's values as its own small array until the end fragments the
    heap so that freed parse buffers are never returned to the system (a 1e7-row
    file then peaked at ~65 bytes per row instead of ~40); one allocation per column,
    sized from the bytes per row of the first block, avoids that. Pipes, whose size is
    unknown, grow by half each time they fill.
    """

    def __init__(self, ncols: int, size_hint):
        self.ncols, self.size_hint, self.rows, self.arrays = ncols, size_hint, 0, None

    def add(self, values: np.ndarray, block_bytes: int) -> None:
        n = len(values)
        if self.arrays is None:
            rows = int(self.size_hint / max(block_bytes / n, 1.0) * 1.02) + n if self.size_hint else 4 * n
            self.arrays = [np.empty(max(rows, n)) for _ in range(self.ncols)]
        if self.rows + n > len(self.arrays[0]):
            grown = max(int(len(self.arrays[0]) * 1.5), self.rows + n)
            for k, old in enumerate(self.arrays):
                self.arrays[k] = np.empty(grown)
                self.arrays[k][: self.rows] = old[: self.rows]
                del old
        for k in range(self.ncols):
            self.arrays[k][self.rows:self.rows + n] = values[:, k]
        self.rows += n

    def finish(self) -> list:
        out = []
        for k in range(self.ncols):
            col = self.arrays[k][: self.rows]
            if len(self.arrays[k]) > 1.1 * self.rows:  # a big overestimate (or a pipe): give it back
                col = col.copy()
            self.arrays[k] = None
            col.setflags(write=False)
            out.append(col)
        return out


def _read_rows(stream, source: str, names: list, sep, first: int, decimal=..., notes=None, size=None,
               text=()) -> dict:
    """Parse every data row after the header (``size`` bytes of them, None if unknown);
    returns name -> float64 column of every column not in ``text`` (appends notes)."""
    ncols = len(names)
    keep = [k for k, n in enumerate(names) if n not in text]
    columns = _Columns(len(keep), size)
    line = first          # file line of the block's first line
    pending_blank = 0     # blank lines seen at the end of the previous block
    carry = b""
    while True:
        chunk = stream.read(BLOCK)
        eof = not chunk
        buf = carry + chunk
        if not eof:
            cut = buf.rfind(b"\n")
            if cut < 0:
                carry = buf
                continue
            buf, carry = buf[: cut + 1], buf[cut + 1:]
        else:
            carry = b""
        body = buf.rstrip(_BLANKS)
        if body:
            if pending_blank:
                raise PendcError(f"{source}: line {line - pending_blank}: blank line, expected {ncols} fields "
                                 f"({', '.join(names)})")
            truncated = eof and not buf.endswith(b"\n")
            if decimal is ...:
                decimal = _detect_decimal(body, sep)
                if decimal == "," and notes is not None:
                    row = body.lstrip(_BLANKS).split(b"\n", 1)[0].decode("utf-8", "replace").strip()
                    notes.append(f"{source}: numbers with decimal commas (first row: {row!r})")
            block = body.replace(b",", b".") if decimal == "," else body
            values = _parse_block(block + b"\n", source, names, sep, line, truncated, keep)
            columns.add(values, len(buf))
            del values
            line += body.count(b"\n") + 1
            pending_blank = max(buf[len(body):].count(b"\n") - 1, 0)
            line += pending_blank
        else:
            n = buf.count(b"\n")
            pending_blank += n
            line += n
        if eof:
            break
    if columns.rows == 0:
        raise PendcError(f"{source}: no data rows after the header (line {first - 1})")
    return dict(zip([names[k] for k in keep], columns.finish()))


def _detect_decimal(body: bytes, sep) -> str:
    """',' when fields are not comma-separated and the first row has commas but no point."""
    first = body.lstrip(_BLANKS).split(b"\n", 1)[0]
    return "," if sep != "," and b"," in first and b"." not in first else "."


def _fields_per_line(a: np.ndarray, ends: np.ndarray, sep) -> np.ndarray:
    """Number of fields on each line of byte array ``a`` (line ends at ``ends``)."""
    if sep is not None:
        pos = np.flatnonzero(a == ord(sep))
        return np.diff(np.searchsorted(pos, ends), prepend=0) + 1
    space = (a == 32) | (a == 9) | (a == 13) | (a == 10)
    starts = ~space
    starts[1:] &= space[:-1]
    pos = np.flatnonzero(starts)
    return np.diff(np.searchsorted(pos, ends), prepend=0)


def _parse_block(block: bytes, source: str, names: list, sep, line: int, truncated: bool,
                 keep: list | None = None) -> np.ndarray:
    """The block's values of the columns ``keep`` (indices; default all), one row per line."""
    a = np.frombuffer(block, dtype=np.uint8)
    ends = np.flatnonzero(a == 10)
    ncols = len(names)
    keep = list(range(ncols)) if keep is None else keep
    use = None if len(keep) == ncols else keep  # usecols only when skipping: the plain call is the fastest
    counts = _fields_per_line(a, ends, sep)
    if np.all(counts == ncols):
        try:
            text = io.StringIO(block.decode("utf-8", errors="replace"))  # str input parses fastest
            values = np.loadtxt(text, delimiter=sep, comments=None, dtype=np.float64, ndmin=2, usecols=use)
        except ValueError:
            values = None
        if values is not None and values.shape == (len(ends), len(keep)):
            return values
    return _diagnose_block(block, source, names, sep, line, truncated, keep)


def _diagnose_block(block: bytes, source: str, names: list, sep, line: int, truncated: bool,
                    keep: list | None = None) -> np.ndarray:
    """Name the first bad line of a block that failed the fast parse, or parse it slowly.

    The slow path returns values only for text that Python's float() reads but
    np.loadtxt does not (e.g. 'Infinity'); the finiteness checks come later.
    """
    rows = []
    keep = list(range(len(names))) if keep is None else keep
    lines = block.decode("utf-8", errors="replace").split("\n")[:-1]
    for k, text in enumerate(lines):
        where = f"{source}: line {line + k}"
        text = text.rstrip("\r")
        if text.startswith("#"):
            raise PendcError(f"{where}: comment line among the data; comments must come before the header")
        fields = text.split(sep) if sep is not None else text.split()
        end = " (the file ends in the middle of a row: truncated?)" if truncated and k == len(lines) - 1 else ""
        if not text.strip():
            raise PendcError(f"{where}: blank line, expected {len(names)} fields ({', '.join(names)})")
        if len(fields) != len(names):
            raise PendcError(f"{where}: {len(fields)} fields, expected {len(names)} fields ({', '.join(names)}){end}")
        fields = [fields[k] for k in keep]
        for name, value in zip([names[k] for k in keep], fields):
            if not _is_number(value) or "_" in value:
                hint = " (decimal comma? give --decimal comma)" if sep != "," and "," in value else ""
                raise PendcError(f"{where}: column '{name}': not a number: {value.strip()!r}{hint}{end}")
        rows.append([float(v) for v in fields])
    return np.array(rows, dtype=np.float64).reshape(len(lines), len(keep))
