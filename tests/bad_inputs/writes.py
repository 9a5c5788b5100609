"""Bad inputs of output folders and of flag values (issue 34's second batch): an empty
``--out``, a dangling or looping symbolic link as ``--out``, and a flag's value refused with the
flag named (``--boundary-layer 0`` was "expected a positive finite phi")."""

from tests.badinput import BadInput

_SRC = "issue 34, second batch"

ROWS: list[BadInput] = [
    BadInput(
        id="out-empty-simulate",
        argv=("simulate", "--tf", "1", "--out", ""),
        exit=2,
        stderr=("expected --out DIR naming a folder, received an empty name ''",),
        sentinels=("summary.json",),
        source=_SRC,
    ),
    BadInput(
        id="out-blank-verify",
        argv=("verify", "liang2016", "--out", "  "),
        exit=2,
        stderr=("expected --out DIR naming a folder, received an empty name",),
        sentinels=("liang2016-verification.md",),
        source=_SRC,
    ),
    BadInput(
        id="out-empty-sweep",
        argv=("sweep", "--design", "pd_consensus", "--graphs", "atlas:4", "--out", ""),
        exit=2,
        stderr=("expected --out DIR naming a folder, received an empty name ''",),
        sentinels=("results.csv",),
        source=_SRC,
    ),
    BadInput(
        id="out-dangling-symlink",
        argv=("simulate", "--tf", "1", "--out", "out"),
        exit=2,
        symlinks={"out": "{d}/nowhere"},
        stderr=("a symbolic link to '{d}/nowhere', which does not resolve",),
        not_in_stderr=("the file",),
        sentinels=("nowhere",),
        source=_SRC,
    ),
    BadInput(
        id="out-under-dangling-symlink",
        argv=("region", "--graph", "ring:3", "--resolution", "2", "--out", "out/sub"),
        exit=2,
        symlinks={"out": "missing"},
        stderr=("received 'out/sub' under 'out', a symbolic link to 'missing'",),
        not_in_stderr=("the file",),
        sentinels=("missing",),
        source=_SRC,
    ),
    BadInput(
        id="out-symlink-loop",
        argv=("simulate", "--tf", "1", "--out", "loop"),
        exit=2,
        symlinks={"loop": "loop"},
        stderr=("a symbolic link to 'loop', which does not resolve (a missing target or a loop)",),
        source=_SRC,
    ),
    BadInput(
        id="boundary-layer-zero-agent-simulate",
        argv=("simulate", "--design", "ma_so3", "--tf", "1", "--boundary-layer", "0"),
        exit=2,
        stderr=("expected a positive --boundary-layer, received 0",),
        not_in_stderr=("phi",),
        source=_SRC,
    ),
    BadInput(
        id="boundary-layer-zero-agent-certify",
        argv=("certify", "--design", "ma_so3", "--boundary-layer", "0"),
        exit=2,
        stderr=("expected a positive --boundary-layer, received '0'",),
        not_in_stderr=("phi",),
        source=_SRC,
    ),
    BadInput(
        id="boundary-layer-zero-lagrangian",
        argv=("simulate", "--tf", "1", "--boundary-layer", "0"),
        exit=2,
        stderr=("expected a positive --boundary-layer, received 0",),
        source=_SRC,
    ),
    BadInput(
        id="torque-limit-zero-agent",
        argv=("simulate", "--design", "ma_so3", "--tf", "1", "--torque-limit", "0"),
        exit=2,
        stderr=("expected a positive --torque-limit, received 0",),
        source=_SRC,
    ),
    BadInput(
        id="angle-tol-negative-agent",
        argv=("simulate", "--design", "ma_so3", "--tf", "1", "--angle-tol", "-1"),
        exit=2,
        stderr=("expected a positive --angle-tol, received -1",),
        not_in_stderr=("angle_tol",),
        source=_SRC,
    ),
    BadInput(
        id="margin-negative-named",
        argv=("certify", "--margin", "-1"),
        exit=2,
        stderr=("(--margin)",),
        source=_SRC,
    ),
    BadInput(
        id="penalty-not-a-number-named",
        argv=("design", "--penalty", "x"),
        exit=2,
        stderr=("expected a number for --penalty",),
        source=_SRC,
    ),
]
