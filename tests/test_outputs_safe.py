"""Outputs never damage what the user has (issue 11, point 4).

Every writer refuses to replace something of another kind with one ``pendc: error:`` line
naming the user's path (never a temporary file), leaves the file system exactly as it was,
and creates files and folders with the mode the umask gives, not mkstemp's private 0700.
"""

import os
import stat
from pathlib import Path

import pytest

from pendc.atomic import write_atomic, write_bytes_atomic
from pendc.backend.emit import write_tree
from pendc.backend.hdl import differences
from pendc.cli import main
from pendc.errors import PendcError


def snapshot(root: Path) -> dict:
    """Every path under ``root`` with its kind, mode and content: what "unchanged" means here."""
    out = {}
    for p in sorted(root.rglob("*")):
        st = p.lstat()
        body = p.read_bytes() if stat.S_ISREG(st.st_mode) else os.readlink(p) if p.is_symlink() else None
        out[str(p.relative_to(root))] = (stat.S_IFMT(st.st_mode), stat.S_IMODE(st.st_mode), body)
    return out


@pytest.fixture
def umask022():
    old = os.umask(0o022)
    yield
    os.umask(old)


def run(argv, capsys):
    code = main(argv)
    err = capsys.readouterr().err
    return code, err


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    errors = [line for line in lines if line.startswith("pendc: error:")]
    assert len(errors) == 1 and "Traceback" not in err, err
    return errors[0]


# --- write_tree: the build folder ------------------------------------------------------------

def test_build_output_onto_an_existing_file_refuses(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("notes.txt").write_text("my notes\n")
    before = snapshot(tmp_path)
    code, err = run(["build", "-o", "notes.txt"], capsys)
    line = one_error_line(err)
    assert code == 2
    assert "notes.txt: is a file; refusing to replace it" in line
    assert snapshot(tmp_path) == before


def test_build_check_on_a_missing_folder_says_it_is_missing(tmp_path, capsys):
    before = snapshot(tmp_path)
    code, err = run(["build", "--check", "-o", str(tmp_path / "nowhere")], capsys)
    line = one_error_line(err)
    assert code == 2 and line == f"pendc: error: {tmp_path / 'nowhere'}: folder does not exist"
    assert snapshot(tmp_path) == before


def test_differences_on_a_file_says_it_is_not_a_folder(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(PendcError, match=r"f: is not a folder"):
        differences(tmp_path / "f", {"a.v": "x"})


@pytest.mark.parametrize("setup, message", [
    (lambda d: (d / "out").write_text("keep me"), "is a file"),
    (lambda d: ((d / "out").mkdir(), (d / "out" / "thesis.tex").write_text("years of work")), "holds thesis.tex"),
    (lambda d: ((d / "out").mkdir(), (d / "out" / "sub").mkdir()), "holds sub"),
    (lambda d: ((d / "real").mkdir(), (d / "out").symlink_to(d / "real")), "is a symbolic link"),
    (lambda d: (d / "out").symlink_to(d / "dangling"), "is a symbolic link"),
])
def test_write_tree_refuses_what_a_build_did_not_write(tmp_path, setup, message):
    setup(tmp_path)
    before = snapshot(tmp_path)
    with pytest.raises(PendcError) as info:
        write_tree(tmp_path / "out", {"core.v": "module m; endmodule\n"})
    assert str(info.value).startswith(f"{tmp_path / 'out'}: {message}")
    assert snapshot(tmp_path) == before


def test_write_tree_replaces_a_previous_build_and_honours_the_umask(tmp_path, umask022):
    write_tree(tmp_path / "out", {"stale.v": "x", "report.json": "{}"})
    write_tree(tmp_path / "out", {"core.v": "module m; endmodule\n"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]   # no temporary left behind
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["core.v"]
    assert stat.S_IMODE((tmp_path / "out").stat().st_mode) == 0o755
    assert stat.S_IMODE((tmp_path / "out" / "core.v").stat().st_mode) == 0o644


def test_write_tree_names_the_users_path_when_the_folder_is_unwritable(tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root writes into read-only folders")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(PendcError, match=rf"^{ro / 'out'}: cannot write the build folder"):
            write_tree(ro / "out", {"a.v": "x"})
    finally:
        ro.chmod(0o755)


def test_write_tree_under_a_file_names_the_users_path(tmp_path):
    (tmp_path / "f").write_text("x")
    before = snapshot(tmp_path)
    with pytest.raises(PendcError) as info:
        write_tree(tmp_path / "f" / "out", {"a.v": "x"})
    assert str(info.value) == f"{tmp_path / 'f' / 'out'}: {tmp_path / 'f'} is not a folder"
    assert ".out." not in str(info.value)
    assert snapshot(tmp_path) == before


# --- write_atomic: every single-file output --------------------------------------------------

def test_simulate_like_output_onto_a_folder_names_the_users_path(tmp_path, capsys):
    (tmp_path / "adir").mkdir()
    before = snapshot(tmp_path)
    code, err = run(["stimulus", "steps", "-o", str(tmp_path / "adir")], capsys)
    line = one_error_line(err)
    assert code == 2 and line == f"pendc: error: {tmp_path / 'adir'}: is a folder; refusing to replace it with a file"
    assert snapshot(tmp_path) == before


def test_write_atomic_into_a_missing_folder(tmp_path):
    with pytest.raises(PendcError, match=r"folder .* does not exist"):
        write_atomic(tmp_path / "no" / "x.csv", "t,u\n")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs a FIFO")
def test_write_atomic_refuses_a_fifo(tmp_path):
    os.mkfifo(tmp_path / "pipe")
    before = snapshot(tmp_path)
    with pytest.raises(PendcError, match=r"pipe: is not a regular file"):
        write_atomic(tmp_path / "pipe", "x")
    assert snapshot(tmp_path) == before


def test_write_atomic_modes_follow_the_umask_and_an_existing_file_keeps_its_own(tmp_path, umask022):
    write_atomic(tmp_path / "new.csv", "a\n")
    assert stat.S_IMODE((tmp_path / "new.csv").stat().st_mode) == 0o644
    (tmp_path / "mine.csv").write_text("old\n")
    (tmp_path / "mine.csv").chmod(0o600)
    write_atomic(tmp_path / "mine.csv", "new\n")
    assert (tmp_path / "mine.csv").read_text() == "new\n"
    assert stat.S_IMODE((tmp_path / "mine.csv").stat().st_mode) == 0o600
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.csv", "new.csv"]


def test_write_atomic_through_a_symlink_keeps_the_link(tmp_path):
    (tmp_path / "real.csv").write_text("old\n")
    (tmp_path / "link.csv").symlink_to("real.csv")
    write_atomic(tmp_path / "link.csv", "new\n")
    assert (tmp_path / "link.csv").is_symlink() and (tmp_path / "real.csv").read_text() == "new\n"


def test_write_bytes_atomic_has_the_same_guarantees(tmp_path, umask022):
    (tmp_path / "a.png").mkdir()
    before = snapshot(tmp_path)
    with pytest.raises(PendcError, match=r"a\.png: is a folder"):
        write_bytes_atomic(tmp_path / "a.png", b"\x89PNG")
    assert snapshot(tmp_path) == before
    write_bytes_atomic(tmp_path / "b.png", b"\x89PNG\r\n")
    assert (tmp_path / "b.png").read_bytes() == b"\x89PNG\r\n"
    assert stat.S_IMODE((tmp_path / "b.png").stat().st_mode) == 0o644


def test_write_atomic_keeps_line_ends_and_unicode(tmp_path):
    write_atomic(tmp_path / "t.txt", "θ = 1\nx\n")
    assert (tmp_path / "t.txt").read_bytes() == "θ = 1\nx\n".encode("utf-8")
