"""The block-wise CSV reader against Python's csv module (an independent parser), at block
sizes small enough that every row, header and error straddles a block boundary somewhere."""

import csv
import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pendc.errors import PendcError
from pendc.sim import csvread


def reference(text: str, sep: str):
    """Columns by Python's csv module and float(): comments and blank lines before the header."""
    lines = [ln for ln in text.splitlines()]
    i = 0
    while lines[i].startswith("#") or not lines[i].strip():
        i += 1
    body = [ln for ln in lines[i:]]
    while body and not body[-1].strip():
        body.pop()
    rows = list(csv.reader(body, delimiter=sep)) if sep != " " else [ln.split() for ln in body]
    names = [n.strip() for n in rows[0]]
    values = np.array([[float(v) for v in r] for r in rows[1:]], dtype=np.float64)
    return {n: values[:, k] for k, n in enumerate(names)}, i + 2


def read(text: str, block: int, monkeypatch):
    monkeypatch.setattr(csvread, "BLOCK", block)
    return csvread.read_csv_table(io.BytesIO(text.encode()), "f.csv")


floats = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=60, deadline=None)
@given(data=st.lists(st.lists(floats, min_size=3, max_size=3), min_size=1, max_size=40),
       sep=st.sampled_from([",", ";", "\t", " "]), crlf=st.booleans(), trailing=st.integers(0, 3),
       pad=st.booleans(), block=st.sampled_from([1, 2, 7, 31, 64, 1000]))
def test_blocks_agree_with_the_csv_module(data, sep, crlf, trailing, pad, block):
    nl = "\r\n" if crlf else "\n"
    gap = " " if pad and sep != " " else ""
    rows = [(gap + sep + gap).join(repr(v) for v in r) for r in data]
    text = "# key: value" + nl + "\n" + sep.join(["a", "b", "c"]) + nl + nl.join(rows) + nl * (1 + trailing)
    want, first = reference(text, sep)
    with pytest.MonkeyPatch.context() as mp:
        got = read(text, block, mp)
    assert list(got.columns) == ["a", "b", "c"] and got.meta == {"key": "value"} and got.first_line == first
    for name in want:
        assert got.columns[name].tobytes() == want[name].tobytes()


@pytest.mark.parametrize("block", [1, 5, 16, 4096])
@pytest.mark.parametrize("text, message", [
    ("a,b\n1,2\n3,4\n\n5,6\n", "line 4: blank line"),
    ("a,b\n1,2\n3,4\n5\n", "line 4: 1 fields, expected 2"),
    ("a,b\n1,2\n3,4\n5,", "line 4: column 'b': not a number: '' (the file ends in the middle of a row"),
    ("a,b\n1,2\n3,x\n5,6\n", "line 3: column 'b': not a number: 'x'"),
    ("a,b\n1,2\n# late\n", "line 3: comment line among the data"),
])
def test_errors_name_the_line_across_block_boundaries(text, message, block, monkeypatch):
    with pytest.raises(PendcError) as info:
        read(text, block, monkeypatch)
    assert message in str(info.value)


def test_no_final_newline_and_trailing_blank_lines_across_blocks(monkeypatch):
    for block in (1, 3, 8):
        got = read("a,b\n1,2\n3,4", block, monkeypatch)
        assert got.columns["b"].tolist() == [2.0, 4.0]
        got = read("a,b\n1,2\n3,4\n\n \n\n", block, monkeypatch)
        assert got.columns["a"].tolist() == [1.0, 3.0]


TEXT_RECORD = ("# generator: pendc hil\n# status: complete\nt,u,x,mode\n"
               "0.000,5.1,0.0,swing\n0.001,5.2,0.5,swing\n0.002,5.3,1.5,balance\n0.003,5.4,2.5,1\n")


@pytest.mark.parametrize("block", [1, 7, 4096])
def test_text_columns_are_skipped_with_one_note(block, monkeypatch):
    monkeypatch.setattr(csvread, "TEXT_SAMPLE", 3)  # the '1' after the sampled rows is text all the same
    got = read(TEXT_RECORD, block, monkeypatch)
    assert list(got.columns) == ["t", "u", "x"] and got.meta == {"generator": "pendc hil", "status": "complete"}
    assert got.columns["x"].tolist() == [0.0, 0.5, 1.5, 2.5] and got.first_line == 4
    assert got.notes == ("f.csv: ignoring text column(s) mode",) and got.text_columns == {"mode": (4, "swing")}
    spaced = read(TEXT_RECORD.replace(",", " "), block, monkeypatch)
    assert [c.tolist() for c in spaced.columns.values()] == [c.tolist() for c in got.columns.values()]


@pytest.mark.parametrize("block", [1, 5, 4096])
@pytest.mark.parametrize("text, message", [
    # a column with numbers among its first rows is numeric: its one bad value is an error, not text
    ("a,mode,b\n1,swing,2\n3,swing,x\n5,swing,6\n", "line 3: column 'b': not a number: 'x'"),
    ("a,b\n1,x\n3,4\n", "line 2: column 'b': not a number: 'x'"),
    ("a,b\n1,\n3,\n", "line 2: column 'b': not a number: ''"),              # blank is no text
    ("a;b\n1.5;0,5\n3.5;0,7\n", "line 2: column 'b': not a number: '0,5' (decimal comma?"),  # not text
    ("a,mode\n1,swing\n2\n", "line 3: 1 fields, expected 2"),
    ("a,mode\n1,swing\n# late\n", "line 3: comment line among the data"),
    ("a,mode\nx,swing\ny,balance\n", "line 2: no column holds numbers (column 'a': 'x')"),
])
def test_text_detection_keeps_the_line_and_column_errors(text, message, block, monkeypatch):
    with pytest.raises(PendcError) as info:
        read(text, block, monkeypatch)
    assert message in str(info.value)


def test_text_detection_reads_only_the_first_rows(monkeypatch):
    rows = "".join(f"{k},{k}\n" for k in range(csvread.TEXT_SAMPLE)) + "99,late\n"
    with pytest.raises(PendcError, match="line 18: column 'b': not a number: 'late'"):
        read("a,b\n" + rows, 64, monkeypatch)
