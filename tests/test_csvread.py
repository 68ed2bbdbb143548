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
