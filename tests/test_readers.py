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


# -- the same refusals through the command line (tests/badinput.py's harness) --------------

def _special(kind: str, p: Path) -> None:
    if kind == "fifo":
        os.mkfifo(p)
    elif kind == "loop":
        p.symlink_to(p.name)
    elif kind == "dangling":
        p.symlink_to("nowhere.txt")
    elif kind == "device":
        p.symlink_to("/dev/zero")
    else:  # a 2 GB sparse file
        with open(p, "wb") as f:
            f.truncate(2 * 1024**3)


@pytest.mark.parametrize("kind, reason", [
    ("fifo", "a FIFO (named pipe), not a regular file"),
    ("loop", "a symlink loop"),
    ("dangling", "a dangling symlink"),
    ("device", "it leaves the folder"),
    ("sparse", "of at most 64 MiB"),
])
def test_special_graph_files_named_by_a_case_are_refused(tmp_path, capsys, kind, reason):
    from tests.bad_inputs.readers import _CASE
    from tests.badinput import BadInput, run_bad_input

    _special(kind, tmp_path / "g.txt")
    row = BadInput(id=f"special-{kind}", argv=("verify", "c.toml", "--out", "o"), exit=2,
                   files={"c.toml": _CASE.replace('graph = "path:3"', 'graph = "g.txt"', 1)},
                   stderr=(reason, "g.txt"))
    run_bad_input(row, tmp_path, capsys)


@pytest.mark.parametrize("kind, reason", [
    ("fifo", "a FIFO (named pipe), not a regular file"),
    ("device", "a device, not a regular file"),
    ("sparse", "of at most 64 MiB"),
])
def test_special_files_on_the_command_line_are_refused(tmp_path, capsys, kind, reason):
    from tests.badinput import BadInput, run_bad_input

    _special(kind, tmp_path / "g.txt")
    row = BadInput(id=f"cli-{kind}", argv=("certify", "--graph", "g.txt"), exit=2,
                   stderr=(reason,))
    run_bad_input(row, tmp_path, capsys)


def test_a_command_line_graph_outside_the_folder_is_the_users(tmp_path):
    from formsync_design.sweep.graphsets import expand_graph_set

    (tmp_path / "graphs").mkdir()
    (tmp_path / "graphs" / "tri.txt").write_text("1 2\n2 3\n3 1\n")
    (tmp_path / "camp").mkdir()
    gs, _ = expand_graph_set("dir:../graphs", base=tmp_path / "camp")  # the command line's
    assert [g.id for g in gs] == ["file:tri.txt"]
    with pytest.raises(InputError, match="it leaves the folder"):  # a campaign file's
        expand_graph_set("dir:../graphs", base=tmp_path / "camp",
                         source=str(tmp_path / "camp" / "c.toml"))


def test_a_symlink_in_a_campaign_graph_folder_cannot_leave_it(tmp_path):
    from formsync_design.sweep.graphsets import expand_graph_set

    (tmp_path / "secret.txt").write_text("1 2\n2 3\n")
    (tmp_path / "camp" / "graphs").mkdir(parents=True)
    (tmp_path / "camp" / "graphs" / "a.txt").symlink_to(tmp_path / "secret.txt")
    with pytest.raises(InputError, match="it leaves the folder"):
        expand_graph_set("dir:graphs", base=tmp_path / "camp",
                         source=str(tmp_path / "camp" / "c.toml"))


def test_an_unknown_metric_message_is_short():
    from formsync_design.verify.metrics import METRICS, metric_spec

    assert len(METRICS) > 50
    for name in ("peak_torqe", "zzzz", "x" * 500):
        with pytest.raises(InputError) as e:
            metric_spec(name, "metrics[1]")
        assert len(str(e.value)) < 250, str(e.value)


def test_a_formula_with_fullwidth_letters_is_refused():
    from formsync_design.safeexpr import parse_formula

    # Python's parser reads the fullwidth 'ｅｘｐ' as exp (NFKC): a look-alike name, refused
    with pytest.raises(InputError, match=r"U\+FF45\) at column 1"):
        parse_formula("\uff45\uff58\uff50(-t)", "reference.rate[1] in c.toml")
    assert str(parse_formula("exp(-t)", "reference.rate[1] in c.toml")) == "exp(-t)"


def test_a_metric_text_argument_is_ascii():
    import formsync_design.verify.metrics_scope  # noqa: F401  (registers large_angle_scope)
    from formsync_design.verify.metrics import METRICS, check_metric_args

    spec = METRICS["large_angle_scope"]
    with pytest.raises(InputError, match=r"metrics\[2\]\.angles.*U\+09ED\) at column 6"):
        check_metric_args(spec, {"angles": "120,1\u09ed0"}, "metrics[2]")
    assert check_metric_args(spec, {"angles": "120,170"}, "metrics[2]")["angles"] == "120,170"


def test_a_metric_spacecraft_within_the_formation_is_accepted():
    from formsync_design.verify.metrics import METRICS, check_metric_args

    spec = METRICS["peak_torque"]
    assert check_metric_args(spec, {"spacecraft": 3}, "metrics[1]", n=3)["spacecraft"] == 3
    assert check_metric_args(spec, {}, "metrics[1]", n=3)["spacecraft"] == 0  # all
    with pytest.raises(InputError, match=r"spacecraft <= 3 .* received 4"):
        check_metric_args(spec, {"spacecraft": 4}, "metrics[1]", n=3)


@pytest.mark.parametrize("kind, reason", [
    ("fifo", "a FIFO (named pipe), not a regular file"),
    ("loop", "a symlink loop"),
    ("device", "a device, not a regular file"),
])
@pytest.mark.parametrize("argv", [("verify", "g.toml"), ("simulate", "--case", "g.toml"),
                                  ("sweep", "--campaign", "g.toml", "--out", "o")])
def test_special_case_and_campaign_files_are_refused(tmp_path, capsys, kind, reason, argv):
    from tests.badinput import BadInput, run_bad_input

    _special(kind, tmp_path / "g.toml")
    run_bad_input(BadInput(id=f"cli-{kind}", argv=argv, exit=2, stderr=(reason,)), tmp_path,
                  capsys)


def test_a_compared_sweeps_files_cannot_be_symlinks_out_of_the_campaign_folder(tmp_path):
    from formsync_design.sweep.campaign import load_campaign

    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "results.csv").write_text("x\n")
    (tmp_path / "camp" / "prior").mkdir(parents=True)
    (tmp_path / "camp" / "prior" / "manifest.json").write_text("{}")
    (tmp_path / "camp" / "prior" / "results.csv").symlink_to(tmp_path / "elsewhere" / "results.csv")
    camp = tmp_path / "camp" / "c.toml"
    camp.write_text('[campaign]\nname = "t"\ngraphs = ["ring:4"]\ncompare = "prior"\n')
    with pytest.raises(InputError, match="campaign.compare.*it leaves the folder"):
        load_campaign(camp)
