"""Integer flags read ASCII digits only (Python's ``int`` reads a Bengali or fullwidth digit)."""

from tests.badinput import BadInput

_SRC = "issue 34 item 3 (command-line numbers, found after the readers' change)"

ROWS: list[BadInput] = [
    BadInput(id="flag-resolution-bengali-digit", argv=("region", "--resolution", "\u09ea"),
             exit=2, stderr=("--resolution", "U+09EA"), source=_SRC),
    BadInput(id="flag-runs-fullwidth-digit", argv=("montecarlo", "--runs", "\uff14"),
             exit=2, stderr=("--runs", "U+FF14"), source=_SRC),
    BadInput(id="flag-seed-fullwidth-digit", argv=("montecarlo", "--seed", "\uff11"),
             exit=2, stderr=("--seed", "U+FF11"), source=_SRC),
    BadInput(id="flag-betas-not-an-integer", argv=("design", "--betas", "4.5"),
             exit=2, stderr=("--betas", "expected an integer"), source=_SRC),
    BadInput(id="flag-workers-arabic-indic-digit", argv=("sweep", "--workers", "\u0662"),
             exit=2, stderr=("--workers", "U+0662"), source=_SRC),
]

# A design file given on the command line is read by the one reader too (issue 34 item 2):
# a FIFO is refused as such, never opened (opening one for reading blocks).
ROWS += [
    BadInput(id="design-file-is-a-folder", argv=("derive", "--design", "{d}/d.py"),
             files={"d.py/keep": ""}, exit=2, stderr=("a folder, not a file",),
             source="issue 34 item 2 (design files on the command line)"),
    BadInput(id="trust-design-dangling-symlink", argv=("verify", "--trust-design", "{d}/x.py"),
             symlinks={"x.py": "{d}/gone.py"}, exit=2, stderr=("a dangling symlink",),
             source="issue 34 item 2 (design files on the command line)"),
]

# An empty --graph is refused as an empty name, not read as the working folder '.'
ROWS += [
    BadInput(id="graph-empty-name", argv=("certify", "--graph", ""), exit=2,
             stderr=("received '' (an empty name)",), not_in_stderr=("received '.'",),
             source="issue 34 (h-tests' report: after the readers' change '' read as '.')"),
]

# --grid out of its range is refused on every path, never clipped or ignored
ROWS += [
    BadInput(id="design-grid-zero-lagrangian", argv=("design", "--grid", "0"), exit=2,
             stderr=("expected --grid in 1..16, received 0",),
             source="issue 34 (h-tests' report: design --grid 0 accepted)"),
    BadInput(id="design-grid-one-agent", argv=("design", "--design", "bai2008_passivity", "--grid", "1"),
             exit=2, stderr=("expected --grid >= 2 for an agent design",),
             source="issue 34 (--grid 1 silently raised to 2 for an agent design)"),
]
