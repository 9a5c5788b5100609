"""The one reader of user files and the one resolver of paths named in data files (issue 34,
item 2): only regular files, a size cap checked before reading, each kind of non-file refused
with its own reason, paths in a data file confined to its folder, file content never echoed
beyond the offending token.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from formsync_design.errors import GraphError, InputError
from formsync_design.textio import (
    MAX_FILE_BYTES,
    check_ascii,
    confined_path,
    cut,
    read_bytes,
    read_text,
)


def _refusal(path: Path | str, match: str) -> str:
    with pytest.raises(InputError, match=match) as e:
        read_text(path, "edge-list file", GraphError)
    assert isinstance(e.value, GraphError)
    assert "\n" not in str(e.value)
    return str(e.value)


def test_a_regular_file_is_read(tmp_path):
    p = tmp_path / "g.txt"
    p.write_text("1 2\n2 3\n")
    assert read_text(p, "edge-list file") == "1 2\n2 3\n"
    assert read_bytes(p, "edge-list file") == b"1 2\n2 3\n"


def test_a_file_read_in_chunks_is_whole(tmp_path):
    p = tmp_path / "big.txt"
    data = b"1 2\n" * (3 * 2**20 // 4 + 7)  # more than two chunks
    p.write_bytes(data)
    assert read_bytes(p, "edge-list file") == data


def test_each_kind_of_non_file_has_its_own_reason(tmp_path):
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")  # never opened: reading a FIFO blocks
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    reasons = {
        _refusal(tmp_path / "folder", "a folder, not a file"),
        _refusal(tmp_path / "fifo", r"a FIFO \(named pipe\), not a regular file"),
        _refusal("/dev/zero", "a device, not a regular file"),
        _refusal(tmp_path / "loop", "a symlink loop"),
        _refusal(tmp_path / "dangling", "a dangling symlink"),
        _refusal(tmp_path / "missing", "no such file"),
    }
    assert len(reasons) == 6


def test_a_2gb_sparse_file_is_refused_before_reading(tmp_path):
    p = tmp_path / "huge.txt"
    with open(p, "wb") as f:
        f.truncate(2 * 1024**3)
    msg = _refusal(p, "of at most 64 MiB")
    assert f"({2 * 1024**3} bytes)" in msg


def test_the_cap_is_inclusive(tmp_path):
    p = tmp_path / "cap.txt"
    with open(p, "wb") as f:
        f.truncate(MAX_FILE_BYTES + 1)
    _refusal(p, "of at most")
    with open(p, "r+b") as f:
        f.truncate(MAX_FILE_BYTES)
    with pytest.raises(InputError, match="a binary file"):  # read, then refused as NULs
        read_text(p, "edge-list file")


def test_binary_and_non_utf8_files(tmp_path):
    p = tmp_path / "g.txt"
    p.write_bytes(b"1 2\x00")
    _refusal(p, "a binary file")
    p.write_bytes(b"1 2 caf\xe9")
    _refusal(p, "byte 7 is not UTF-8")


@pytest.mark.parametrize("text, reason", [
    ("../../../../etc/passwd", "it leaves the folder"),
    ("sub/../../x.txt", "it leaves the folder"),
    ("/etc/passwd", "an absolute path"),
    ("~/x.txt", "an absolute path"),
])
def test_a_path_in_a_data_file_stays_in_its_folder(tmp_path, text, reason):
    case = tmp_path / "c.toml"
    with pytest.raises(InputError, match=reason) as e:
        confined_path(text, case, "formations[2].graph")
    assert "formations[2].graph" in str(e.value) and str(case) in str(e.value)


def test_a_symlink_out_of_the_folder_is_refused(tmp_path):
    (tmp_path / "cases").mkdir()
    (tmp_path / "secret.txt").write_text("1 2\n")
    (tmp_path / "cases" / "g.txt").symlink_to(tmp_path / "secret.txt")
    with pytest.raises(InputError, match="it leaves the folder"):
        confined_path("g.txt", tmp_path / "cases" / "c.toml", "case.graph")


def test_a_path_inside_the_folder_is_kept_as_written(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "g.txt").write_text("1 2\n")
    (tmp_path / "link.txt").symlink_to(tmp_path / "sub" / "g.txt")
    case = tmp_path / "c.toml"
    assert confined_path("sub/g.txt", case, "k") == tmp_path / "sub" / "g.txt"
    assert confined_path("sub/../link.txt", case, "k") == tmp_path / "sub/../link.txt"
    assert confined_path("d/x", case, "k", base=tmp_path / "sub") == tmp_path / "sub" / "d" / "x"


def test_cut_keeps_a_few_dozen_characters():
    line = "root:x:0:0:root:/root:/bin/bash"
    assert len(cut(line)) <= 25 and cut(line).endswith("…'")
    assert line not in cut(line)
    assert cut("1 2") == "'1 2'"


@pytest.mark.parametrize("text, col, code", [
    ("peak < \u09ea", 8, "U+09EA"),       # Bengali four, which looks like an 8
    ("ring:\uff14", 6, "U+FF14"),          # fullwidth four
    ("t\u0430 < 1", 2, "U+0430"),          # Cyrillic a, a Latin look-alike
])
def test_non_ascii_characters_are_refused_with_their_column(text, col, code):
    with pytest.raises(InputError, match=f"at column {col}") as e:
        check_ascii(text, "the predicate")
    assert code in str(e.value)
