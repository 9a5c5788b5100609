"""Stage 3 — design specifications: the controller/Lyapunov contract and its loader."""

from formsync_design.spec.loader import (
    ControllerView,
    LyapunovView,
    Spec,
    default_spec_path,
    gain_symbols,
    load_spec,
    validate_spec,
)

__all__ = [
    "ControllerView",
    "LyapunovView",
    "Spec",
    "load_spec",
    "validate_spec",
    "default_spec_path",
    "gain_symbols",
]
