"""Stage 3 — designs: the plug-in contract (controller, Lyapunov candidate, declared gains,
representation, graph class, sampling) and its loader."""

from formsync_design.spec.declarations import (
    CLASSIC,
    Declarations,
    GainDecl,
    GainKind,
    GainRole,
    parse_declarations,
)
from formsync_design.spec.loader import (
    ControllerView,
    LyapunovView,
    Spec,
    default_spec_path,
    gain_symbols,
    load_spec,
    validate_spec,
)

#: A design is a :class:`Spec` (the same type; "design" is the user-facing word).
Design = Spec
#: :func:`load_spec` under the user-facing name: a shipped design's name, a file, or a Spec.
load_design = load_spec

__all__ = [
    "CLASSIC",
    "ControllerView",
    "Declarations",
    "Design",
    "GainDecl",
    "GainKind",
    "GainRole",
    "LyapunovView",
    "Spec",
    "default_spec_path",
    "gain_symbols",
    "load_design",
    "load_spec",
    "parse_declarations",
    "validate_spec",
]
