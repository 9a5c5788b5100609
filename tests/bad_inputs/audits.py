"""Bad inputs from the earlier audits (issue 34's first batches and before)."""

from tests.badinput import BadInput

ROWS: list[BadInput] = [
    BadInput(
        id="graph-spec-unknown-kind",
        argv=("certify", "--graph", "torus:8"),
        exit=2,
        stderr=("expected",),
        source="earlier audits",
    ),
]
