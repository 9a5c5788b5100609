"""Bad inputs of the readers (issue 34, items 2 and 3): paths in data files confined to their
folder, file content never echoed beyond the offending token, ASCII-only numbers and names,
metric arguments checked against the formation, short messages.

The rows mutate ``tests/data/small_case.toml`` (a 3-spacecraft engine case: formations
``ring3`` and ``path3``, metrics ``t_ring3`` ... ``sat_ring3``); every one is refused while
the case is read, before anything is simulated.
"""

from pathlib import Path

from tests.badinput import BadInput

_CASE = (Path(__file__).resolve().parents[1] / "data" / "small_case.toml").read_text()
_SRC = "issue 34 items 2-3"
_PASSWD = "root:x:0:0:root:/root:/bin/bash"


def _case(old: str, new: str) -> str:
    assert old in _CASE, old
    return _CASE.replace(old, new, 1)


def _graph(text: str) -> str:
    """The case with formation path3's graph replaced by ``text`` (TOML-quoted as given)."""
    return _case('graph = "path:3"', f"graph = {text}")


def _verify(case: str, **files: str | bytes) -> dict[str, str | bytes]:
    return {"c.toml": case, **files}


_PEAK = '\n[[metrics]]\nid = "peak99"\nmetric = "peak_torque"\nformation = "ring3"\n'

ROWS: list[BadInput] = [
    BadInput(
        id="readers-formation-graph-dotdot-passwd",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_graph('"../../../../../../etc/passwd"')),
        stderr=("formations[2].graph", "it leaves the folder"),
        not_in_stderr=("root:x",),
        source=_SRC,
    ),
    BadInput(
        id="readers-formation-graph-absolute",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_graph('"/etc/passwd"')),
        stderr=("formations[2].graph", "an absolute path"),
        not_in_stderr=("root:x",),
        source=_SRC,
    ),
    BadInput(
        id="readers-formation-graph-absolute-to-a-valid-file-beside",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_graph('"{d}/g.txt"'), **{"g.txt": "1 2\n2 3\n"}),
        stderr=("an absolute path",),
        source=_SRC,
    ),
    BadInput(
        id="readers-case-graph-outside-the-case-folder",
        argv=("verify", "sub/c.toml", "--out", "o"),
        exit=2,
        files={"sub/c.toml": _case('graph = "ring:3"', 'graph = "../g.txt"'),
               "g.txt": "1 2\n2 3\n3 1\n"},
        stderr=("case.graph", "it leaves the folder"),
        source=_SRC,
    ),
    BadInput(
        id="readers-formation-graph-a-folder",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_graph('"d"'), **{"d/x.txt": "1 2\n"}),
        stderr=("a folder, not a file",),
        source=_SRC,
    ),
    BadInput(
        id="readers-graph-file-content-cut-to-the-token",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_graph('"g.txt"'), **{"g.txt": _PASSWD + "\n"}),
        stderr=("root:x:0:0", "g.txt:1"),
        not_in_stderr=(_PASSWD,),
        source=_SRC,
    ),
    BadInput(
        id="readers-graph-file-bengali-digit",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_graph('"g.txt"'), **{"g.txt": "1 2\n2 \u09e9\n"}),
        stderr=("digits 0-9", "g.txt:2, column 3"),
        source=_SRC,
    ),
    BadInput(
        id="readers-graph-spec-fullwidth-digit",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_graph('"path:\uff13"')),
        stderr=("U+FF13", "column 6"),
        source=_SRC,
    ),
    BadInput(
        id="readers-graph-spec-cycle-bengali-digit",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_graph('"cycle:\u09e9"')),
        stderr=("formations[2].graph", "U+09E9", "column 7"),
        source=_SRC,
    ),
    BadInput(
        id="readers-predicate-bengali-digit",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_case('predicate = "sat_ring3 <= 10"', 'predicate = "sat_ring3 < \u09ea"')),
        stderr=("claim saturation's predicate", "U+09EA", "column 13"),
        source=_SRC,
    ),
    BadInput(
        id="readers-predicate-fullwidth-digit",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_case('predicate = "sat_ring3 <= 10"', 'predicate = "sat_ring3 <= \uff11\uff10"')),
        stderr=("U+FF11", "column 14"),
        source=_SRC,
    ),
    BadInput(
        id="readers-metric-spacecraft-beyond-the-formation",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_CASE + _PEAK + "spacecraft = 99\n"),
        stderr=("metrics[7].spacecraft <= 3", "received 99"),
        source=_SRC,
    ),
    BadInput(
        id="readers-predicate-verdict-vs-number-in-order",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_case('predicate = "sat_ring3 <= 10"', 'predicate = "pi_ring3 == 3"')),
        stderr=("received a text and a number (left, right)",),
        source=_SRC,
    ),
    BadInput(
        id="readers-predicate-number-vs-verdict-in-order",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_case('predicate = "sat_ring3 <= 10"', 'predicate = "3 == pi_ring3"')),
        stderr=("received a number and a text (left, right)",),
        source=_SRC,
    ),
    BadInput(
        id="readers-unknown-metric-lists-the-closest-few",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_CASE + '\n[[metrics]]\nid = "peak"\nmetric = "peak_torqe"\n'),
        stderr=("metrics[7].metric", "closest: peak_torque"),
        not_in_stderr=("formation_certificate", "relative_convergence_time"),
        source=_SRC,
    ),
    BadInput(
        id="readers-unknown-metric-id-in-a-predicate",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_case('predicate = "sat_ring3 <= 10"', 'predicate = "sat_rin3 <= 10"')),
        stderr=("closest: sat_ring3",),
        source=_SRC,
    ),
    BadInput(
        id="readers-case-name-a-path",
        argv=("verify", "c.toml", "--out", "o"),
        exit=2,
        files=_verify(_case('name = "small3"', 'name = "../../../x"')),
        stderr=("case.name", "'../../../x'"),
        source=_SRC,
    ),
    BadInput(
        id="readers-campaign-graph-file-outside-its-folder",
        argv=("sweep", "--campaign", "sub/c.toml", "--out", "o"),
        exit=2,
        files={"sub/c.toml": '[campaign]\nname = "t"\ngraphs = ["../g.txt"]\n',
               "g.txt": "1 2\n2 3\n3 1\n"},
        stderr=("campaign.graphs", "it leaves the folder"),
        source=_SRC,
    ),
    BadInput(
        id="readers-campaign-graph-folder-absolute",
        argv=("sweep", "--campaign", "c.toml", "--out", "o"),
        exit=2,
        files={"c.toml": '[campaign]\nname = "t"\ngraphs = ["dir:/etc"]\n'},
        stderr=("campaign.graphs", "an absolute path"),
        source=_SRC,
    ),
    BadInput(
        id="readers-campaign-compare-outside-its-folder",
        argv=("sweep", "--campaign", "sub/c.toml", "--out", "o"),
        exit=2,
        files={"sub/c.toml": '[campaign]\nname = "t"\ngraphs = ["ring:4"]\ncompare = "../r"\n',
               "r/manifest.json": "{}", "r/results.csv": ""},
        stderr=("campaign.compare", "it leaves the folder"),
        source=_SRC,
    ),
    BadInput(
        id="readers-campaign-montecarlo-case-outside-its-folder",
        argv=("sweep", "--campaign", "sub/c.toml", "--out", "o"),
        exit=2,
        files={"sub/c.toml": '[campaign]\nname = "t"\ngraphs = ["ring:3"]\n'
                             '[montecarlo]\nruns = 2\ncase = "../case.toml"\n',
               "case.toml": _CASE},
        stderr=("montecarlo.case", "it leaves the folder"),
        source=_SRC,
    ),
    BadInput(
        id="readers-campaign-graph-range-bengali-digit",
        argv=("sweep", "--campaign", "c.toml", "--out", "o"),
        exit=2,
        files={"c.toml": '[campaign]\nname = "t"\ngraphs = ["ring:4..\u09ec"]\n'},
        stderr=("U+09EC", "column 9"),
        source=_SRC,
    ),
]
