"""Stage 3 — designs: the plug-in contract (controller, Lyapunov candidate, declared gains,
representation, graph class, sampling) and its loader."""

from formsync_design.spec.agent import AgentDesign
from formsync_design.spec.agent_view import AgentDeclarations, AgentView
from formsync_design.spec.declarations import (
    CLASSIC,
    Declarations,
    GainDecl,
    GainKind,
    GainRole,
    parse_declarations,
)
from formsync_design.spec.lagrangian_view import ControllerView, LyapunovView
from formsync_design.spec.loader import (
    Spec,
    default_spec_path,
    gain_symbols,
    load_design,
    load_spec,
    validate_spec,
)

#: A design is a :class:`Spec` (the same type; "design" is the user-facing word).
Design = Spec

__all__ = [
    "AgentDeclarations",
    "AgentDesign",
    "AgentView",
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
