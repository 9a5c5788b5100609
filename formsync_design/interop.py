"""python-control interop: a design's formation linearisation as a ``control.StateSpace``.

:func:`to_statespace` exports the exact linearisation the formation certificate decides
(:func:`~formsync_design.derive.formation.linearize_formation`: at consensus, or at the
reference for a leader design), at given gains, with the disturbance torques as inputs
(``d1_1 .. d3_N``, N m) and the attitude errors as outputs (the chart coordinates ``q``,
``sigma`` or ``theta`` of every spacecraft: the vector part of the attitude error to the
reference, or of the attitude itself at consensus), so a user runs ``control.bode``,
``control.step_response``, ``control.pzmap``, margins or H-infinity norms on it.  The state
order is the linearisation's (``LinearLoop.labels``), named in the system's ``states``.
A Lagrangian design (``liang2016``, ``pd_consensus``) is exported from its derived, cancelled
closed loop (:func:`~formsync_design.derive.lagrangian_linear.linearize_lagrangian`: state
``(q, q')``, consensus at the identity), the same system as its agent form's up to the
change of coordinates ``q' = w / 2``.

python-control is an optional dependency (``pip install 'formsync-design[control]'``).

>>> import numpy as np
>>> from formsync_design.spec.loader import load_design
>>> sys = to_statespace(load_design("lv2012"), "path:2", [np.eye(3) * 2] * 2,
...                     {"k_p": 1, "k_d": 4, "a_f": 1}, pinning=[1, 1])
>>> sys.ninputs, sys.noutputs, sys.nstates
(6, 6, 18)
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError

__all__ = ["formation_matrices", "to_statespace"]


def formation_matrices(design: Any, graph: Any, inertias: Any, gains: Mapping[str, Any], *,
                       switch: str = "sat", phi: Any = "1/100", pinning: Any = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[str, ...]]:
    """``(A, B, C, state labels)`` of ``x' = A x + B d``, ``z = C x`` at ``gains`` (floats of
    the exact linearisation; every controller gain needs a value, and a Lagrangian design's
    switching gain too).  ``design`` is an agent or a Lagrangian design, or its name or file.

    >>> A, B, C, labels = formation_matrices("liang2016", "path:2", [np.eye(3)] * 2,
    ...                                      {"K_o": 1.6, "K_q": 0.4, "beta": 0.3, "K_v": 0.01})
    >>> A.shape, labels[6]
    ((12, 12), 'qd1_1')
    """
    from formsync_design.derive.formation import linearize_formation
    from formsync_design.gains import parse_number
    from formsync_design.spec.declarations import GainRole
    from formsync_design.spec.loader import Spec

    design = _design(design)
    plant = getattr(design.decl, "plant", "attitude")
    if plant != "attitude":
        raise InputError(f"expected a formation design (agent or Lagrangian) for the export, "
                         f"received {design.name} (on the {plant} plant: one spacecraft, "
                         f"no formation)")
    if isinstance(design, Spec):  # a Lagrangian design: its derived, cancelled loop
        from formsync_design.derive.lagrangian_linear import linearize_lagrangian

        if pinning is not None:
            raise InputError(f"expected no pinning for the Lagrangian design {design.name} "
                             f"(it has no leader), received {pinning!r}")
        ll = linearize_lagrangian(design, graph, inertias, gains, switch=switch, phi=phi)
        return ll.A, ll.B, ll.C, ll.labels
    ctrl = [g.name for g in design.decl.gains if g.role == GainRole.CONTROLLER]
    missing = [g for g in ctrl if g not in gains]
    if missing:
        raise InputError(f"expected a value for every controller gain {ctrl} of {design.name}, "
                         f"missing {missing}")
    fixed = {g: parse_number(gains[g], g) for g in ctrl}
    lin = linearize_formation(design, graph, inertias, switch=switch, phi=phi, fixed=fixed,
                              pinning=pinning)
    if lin.loop is None:
        raise InputError(f"expected a law differentiable at the equilibrium for the export of "
                         f"{design.name}, received {lin.why}")
    A, B, C = lin.loop.standard({})
    return A, B, C, lin.loop.labels


def _design(design: Any) -> Any:
    """A design value from a design, a shipped design's name or a design file (the name or
    file of a design with a Lagrangian view: that view, as every stage taking both forms)."""
    if isinstance(design, (str, Path)):
        from formsync_design.spec.loader import lagrangian_view, load_design

        d = load_design(design)
        return lagrangian_view(d) or d
    return design


def to_statespace(design: Any, graph: Any, inertias: Any, gains: Mapping[str, Any], *,
                  switch: str = "sat", phi: Any = "1/100", pinning: Any = None) -> Any:
    """The formation linearisation as a ``control.StateSpace`` (module docstring)."""
    try:
        import control
    except ImportError:
        raise InputError("expected python-control for to_statespace (pip install "
                         "'formsync-design[control]'), received no module 'control'") from None
    design = _design(design)
    A, B, C, labels = formation_matrices(design, graph, inertias, gains, switch=switch, phi=phi,
                                         pinning=pinning)
    n = B.shape[1] // 3
    inputs = [f"d{k}_{i + 1}" for i in range(n) for k in (1, 2, 3)]
    return control.ss(A, B, C, np.zeros((C.shape[0], B.shape[1])), states=list(labels),
                      inputs=inputs, outputs=list(labels[: C.shape[0]]),
                      name=f"{design.name}-formation")
