"""Bad inputs of the trust model for design code and of misbehaving design code (issue 34,
items 1 and 4): a data file never makes code run without the user's flag, a shipped
design's name is never shadowed, and design code that hangs or exits is one line, exit 2.

The time-limit rows need ``FORMSYNC_DESIGN_TIMEOUT`` set and live in ``tests/test_trust.py``
(:data:`TIMEOUT_ROWS`, run there with the limit lowered).
"""

from tests.badinput import PAYLOAD, BadInput

_SOURCE = "issue 34 items 1 and 4"

#: An engine case on two spacecraft; ``{design}`` is its ``[case] design``.
CASE = """
[case]
kind = "engine"
design = "{design}"
graph = "path:2"
[gains]
k_p = 0.4
k_d = 1.6
[simulation]
tf = 5.0
[[spacecraft]]
inertia = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
rate = [0.1, 0, 0]
q = [0, 0, 0]
[[spacecraft]]
inertia = [[2, 0, 0], [0, 2, 0], [0, 0, 2]]
rate = [0, 0.05, 0]
q = [0, 0, 0]
[[metrics]]
id = "w"
metric = "final_rate"
[[claims]]
id = "damped"
text = "the rates decay"
predicate = "w < 1"
"""

#: A campaign of the shipped ma_so3 with a reference naming a gain it does not have: refused
#: (exit 2) after the design is resolved and loaded, before any work.
CAMPAIGN = """
[campaign]
name = "c"
graphs = ["ring:3"]
design = "{design}"
[reference]
zzz = 1
"""

_VERIFY = ("verify", "case.toml", "--out", "o")


def _case(design: str) -> str:
    return CASE.replace("{design}", design)


def _design(body: str) -> str:
    """An agent design file whose controller is ``body`` (indented)."""
    return ('FORM = "agent"\nGAINS = {"k": {}}\n\n\ndef controller(v):\n'
            + "".join(f"    {ln}\n" for ln in body.splitlines()))


ROWS: list[BadInput] = [
    BadInput(
        id="trust-case-design-absolute-path",
        files={"elsewhere/evil.py": PAYLOAD, "case.toml": _case("{d}/elsewhere/evil.py")},
        argv=_VERIFY, exit=2, stderr=("case.design", "an absolute path"),
        sentinels=("PWNED", "elsewhere/PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-case-design-dotdot-escape",
        files={"elsewhere/evil.py": PAYLOAD, "cases/case.toml": _case("../elsewhere/evil.py")},
        argv=("verify", "cases/case.toml", "--out", "o"), exit=2,
        stderr=("case.design", "leads outside that folder"),
        sentinels=("elsewhere/PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-case-design-dotdot-even-when-trusted",
        files={"elsewhere/evil.py": PAYLOAD, "cases/case.toml": _case("../elsewhere/evil.py")},
        argv=("verify", "cases/case.toml", "--out", "o", "--trust-design", "elsewhere/evil.py"),
        exit=2, stderr=("leads outside that folder",),
        sentinels=("elsewhere/PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-case-design-not-a-py-file",
        files={"notes.txt": PAYLOAD, "case.toml": _case("notes.txt")},
        argv=_VERIFY, exit=2, stderr=("'notes.txt' (not a .py file)",),
        sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-case-design-file-beside-it-needs-the-flag",
        files={"x.py": PAYLOAD, "case.toml": _case("x.py")},
        argv=_VERIFY, exit=2,
        stderr=("the file x.py (sha256 ", "run it only if you trust it: --trust-design x.py"),
        sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-case-design-trusted-other-file-is-not-this-one",
        files={"x.py": PAYLOAD, "y.py": "", "case.toml": _case("x.py")},
        argv=(*_VERIFY, "--trust-design", "y.py"), exit=2,
        stderr=("--trust-design x.py",), sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-case-unknown-name-is-not-a-file",
        files={"ma_so4": PAYLOAD, "case.toml": _case("ma_so4")},
        argv=_VERIFY, exit=2, stderr=("'ma_so4' (not a shipped design)",),
        sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-scenario-design-file-needs-the-flag",
        files={"x.py": PAYLOAD, "case.toml": _case("pd_consensus") + """
[[scenarios]]
name = "nominal"
[[scenarios]]
name = "other"
design = "x.py"
gains = {k = 1.0}
"""},
        argv=_VERIFY, exit=2, stderr=("'x.py'", "--trust-design x.py"),
        sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-simulate-case-design-file-needs-the-flag",
        files={"x.py": PAYLOAD, "case.toml": _case("x.py")},
        argv=("simulate", "--case", "case.toml", "--out", "o"), exit=2,
        stderr=("--trust-design x.py",), sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-campaign-file-beside-it-does-not-shadow-ma_so3",
        files={"ma_so3": PAYLOAD, "c.toml": CAMPAIGN.replace("{design}", "ma_so3")},
        argv=("sweep", "--campaign", "c.toml", "--workers", "0", "--out", "o"), exit=2,
        stderr=("zzz",), not_in_stderr=("ma_so3.py",),
        sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-sweep-design-name-in-a-folder-with-that-file-is-the-shipped-one",
        files={"ma_so3": PAYLOAD},
        argv=("sweep", "--design", "ma_so3", "--graphs", "ring:3", "--ref", "zzz=1",
              "--workers", "0", "--out", "o"),
        exit=2, stderr=("--ref",), sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-campaign-design-absolute-path-without-py-never-runs",
        files={"evil": PAYLOAD, "c.toml": CAMPAIGN.replace("{design}", "{d}/evil")},
        argv=("sweep", "--campaign", "c.toml", "--workers", "0", "--out", "o"), exit=2,
        stderr=("campaign.design", "an absolute path"), sentinels=("PWNED", "o"),
        source=_SOURCE,
    ),
    BadInput(
        id="trust-campaign-design-file-beside-it-needs-the-flag",
        files={"mine.py": PAYLOAD, "c.toml": CAMPAIGN.replace("{design}", "mine.py")},
        argv=("sweep", "--campaign", "c.toml", "--workers", "0", "--out", "o"), exit=2,
        stderr=("--trust-design mine.py",), sentinels=("PWNED", "o"), source=_SOURCE,
    ),
    BadInput(
        id="trust-flag-names-a-missing-file",
        argv=("verify", "liang2016", "--out", "o", "--trust-design", "nope.py"), exit=2,
        stderr=("expected a --trust-design design .py file", "no such file"),
        sentinels=("o",), source=_SOURCE,
    ),
    BadInput(
        id="design-representation-unhashable",
        files={"rep.py": 'REPRESENTATION = ["quaternion"]\n' + _design("return -v.k * v.J * v.w")},
        argv=("certify", "--design", "rep.py", "--graph", "ring:3"), exit=2,
        stderr=("REPRESENTATION", "expected one of"), not_in_stderr=("internal error",),
        source=_SOURCE,
    ),
    BadInput(
        id="design-sampling-unhashable",
        files={"s.py": 'SAMPLING = {"rule": "periodic"}\n' + _design("return -v.k * v.J * v.w")},
        argv=("certify", "--design", "s.py", "--graph", "ring:3"), exit=2,
        stderr=("SAMPLING",), not_in_stderr=("internal error",), source=_SOURCE,
    ),
    BadInput(
        id="design-plant-unhashable",
        files={"p.py": 'PLANT = ["attitude"]\n' + _design("return -v.k * v.J * v.w")},
        argv=("certify", "--design", "p.py", "--graph", "ring:3"), exit=2,
        stderr=("PLANT",), not_in_stderr=("internal error",), source=_SOURCE,
    ),
    BadInput(
        id="design-measured-not-a-list",
        files={"m.py": "MEASURED = 3\n" + _design("return -v.k * v.J * v.w")},
        argv=("certify", "--design", "m.py", "--graph", "ring:3"), exit=2,
        stderr=("MEASURED",), not_in_stderr=("internal error",), source=_SOURCE,
    ),
    BadInput(
        id="design-controller-raises-systemexit-0",
        files={"bad.py": _design("raise SystemExit(0)")},
        argv=("certify", "--design", "bad.py", "--graph", "ring:3"), exit=2,
        stderr=("bad.py", "expected the design code to return", "SystemExit(0)"),
        source=_SOURCE,
    ),
    BadInput(
        id="design-raises-generatorexit-at-import",
        files={"bad.py": "raise GeneratorExit\n" + _design("return -v.k * v.J * v.w")},
        argv=("simulate", "--design", "bad.py"), exit=2,
        stderr=("bad.py", "GeneratorExit"), source=_SOURCE,
    ),
    BadInput(
        id="design-calls-sys-exit-at-import",
        files={"bad.py": "import sys\nsys.exit(0)\n"},
        argv=("simulate", "--design", "bad.py"), exit=2,
        stderr=("bad.py", "SystemExit(0)"), source=_SOURCE,
    ),
]

#: Rows of design code that does not finish: run with ``FORMSYNC_DESIGN_TIMEOUT=1``.
TIMEOUT_ROWS: list[BadInput] = [
    BadInput(
        id="design-loops-forever-at-import",
        files={"spin.py": "while True:\n    pass\n"},
        argv=("simulate", "--design", "spin.py"), exit=2,
        stderr=("spin.py", "within 1 s", "FORMSYNC_DESIGN_TIMEOUT"), source=_SOURCE,
    ),
    BadInput(
        id="design-controller-loops-forever",
        files={"spin.py": _design("while True:\n    pass")},
        argv=("certify", "--design", "spin.py", "--graph", "ring:3"), exit=2,
        stderr=("spin.py", "within 1 s", "FORMSYNC_DESIGN_TIMEOUT"), source=_SOURCE,
    ),
]
