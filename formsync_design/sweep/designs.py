"""What a campaign takes from its design: the design itself, its gain schema and the
default gain box and reference point.

A campaign runs one design (``[campaign] design = NAME|FILE``, ``--design``; default
liang2016).  Its ``[reference]`` and ``[[box]]`` tables are keyed by the design's
*controller gains*; the Lyapunov-candidate multipliers are searched over their declared
ranges by every certificate (never given), and the switching gain is a Monte-Carlo
setting only (``[montecarlo] K_v`` for liang2016).  Defaults:

* box: each controller gain's declared range; liang2016's gains, which declare none,
  take the standard box :data:`DEFAULT_BOX`;
* reference: liang2016's gains the paper's point :data:`DEFAULT_REFERENCE`; another
  design the gains of its shipped case (``verification/NAME.toml``), else the campaign
  must give ``[reference]``.

An agent design (``FORM = "agent"``, :mod:`formsync_design.spec.agent`) is swept as
``formsync certify``, ``region`` and ``design`` run it (:mod:`formsync_design.certify.agent`):
it needs a ``conditions(c)`` hook, each box at most three free axes counting the searched
multipliers (:func:`check_agent_box`); its ``[montecarlo]`` runs its agent case
(:mod:`formsync_design.sweep.mccase`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.gains import parse_number
from formsync_design.sweep.schema import GAINS, SweepSchema, rational_text

__all__ = ["DEFAULT_BOX", "DEFAULT_REFERENCE", "load_design", "check_sweepable", "gain_key_error",
           "default_box", "default_reference", "is_default_design", "is_shipped",
           "check_agent_box"]

DEFAULT_BOX = {"name": "standard", "K_o": ["0.05", "5"], "K_q": ["0.05", "5"], "beta": ["0.01", "1"]}
DEFAULT_REFERENCE = {"K_o": "1.6", "K_q": "0.4", "beta": "0.3"}


def load_design(ref: Any = None, data_file: str | Path | None = None) -> Any:
    """The design named by ``ref`` (a :class:`~formsync_design.spec.loader.Spec` or an
    agent design): a design value, a shipped design's name (always the shipped file), a
    ``.py`` file, or ``None`` / ``""`` for liang2016.  ``data_file``: the campaign file that
    names ``ref`` (it may name only a trusted ``.py`` file beside itself:
    :func:`~formsync_design.spec.trust.resolve_design_ref`); ``None``: the user named it (a
    path relative to the current folder).  A design with a Lagrangian view is swept in that
    view (the campaign derives its Theta_i / Pi conditions); an agent design without one, in
    its agent form.

    >>> load_design("pd_consensus").name, load_design().name, load_design("ma_so3").form
    ('pd_consensus', 'liang2016', 'agent')
    >>> type(load_design("pd_consensus")).__name__, type(load_design("ma_so3")).__name__
    ('Spec', 'AgentDesign')
    """
    from formsync_design.spec.loader import Spec, lagrangian_view, load_design as load_any
    from formsync_design.spec.trust import resolve_design_ref

    if isinstance(ref, Spec) or getattr(ref, "form", None) == "agent":
        return lagrangian_view(ref) or ref
    if ref is None or (isinstance(ref, str) and not ref.strip()):
        d = load_any(None)
    elif data_file is not None:
        d = load_any(resolve_design_ref(ref, data_file, "campaign.design"))
    else:
        d = load_any(ref)  # a shipped name first, else the file; other types refused (one line)
    return lagrangian_view(d) or d


def is_default_design(spec: Any) -> bool:
    """Whether ``spec`` is the shipped liang2016 design (its content)."""
    from formsync_design.spec.loader import load_spec

    return bool(spec.key == load_spec(None).key)


def check_sweepable(spec: Any) -> SweepSchema:
    """The schema of ``spec``, refusing (one line) a design the sweep cannot run.

    A sweep derives the design's conditions (a derivable representation) and runs a
    region map and a gain design per task: three family dimensions (two optimized by
    the SDP, the third swept), as ``formsync region`` and ``formsync design`` need.

    >>> from formsync_design.spec.loader import load_spec
    >>> check_sweepable(load_spec("pd_consensus")).box
    ('k_p', 'k_d')
    >>> print(check_sweepable(load_design("ma_quat_smc")))
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected an agent design with a conditions(c) hook (its certificate) for a sweep, received design ma_quat_smc without one
    """
    from formsync_design.spec.declarations import DERIVABLE

    if getattr(spec, "form", None) == "agent":
        if not callable(spec.module.get("conditions")):
            raise InputError(f"expected an agent design with a conditions(c) hook (its "
                             f"certificate) for a sweep, received design {spec.name} without one")
        return SweepSchema.of_design(spec)
    if spec.representation not in DERIVABLE:
        raise InputError(f"expected a design in a derivable representation ({', '.join(DERIVABLE)}) "
                         f"for a sweep, received design {spec.name} in {spec.representation!r}")
    schema = SweepSchema.of_design(spec)
    if len(schema.family) != 3:
        raise InputError(
            f"expected a design with three box dimensions (controller gains and multipliers) for "
            f"a sweep's region map and gain design, received design {spec.name} with "
            f"{', '.join(schema.family)}"
        )
    return schema


def check_agent_box(spec: Any, schema: SweepSchema, name: str,
                    bounds: Any) -> None:
    """Refuse (one line) a box of an agent design with more than three free axes counting
    the searched multipliers (a region map has three: fix the others at one value).

    >>> from fractions import Fraction as F
    >>> d = load_design("ma_so3")
    >>> s = check_sweepable(d)
    >>> check_agent_box(d, s, "b", [(F(1), F(2)), (F(1, 10), F(1, 5))] + [(F(1, 20),) * 2] * 3)
    >>> check_agent_box(d, s, "std", [(F(1), F(2))] * 3 + [(F(1, 20),) * 2] * 2)
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected at most three free axes in box 'std' of design ma_so3 (its region map; the multipliers mu are searched), received ranges for K1, K2, P1; give the others a single value
    """
    free = [g for g, (lo, hi) in zip(schema.box, bounds) if lo != hi]
    if len(free) + len(schema.multipliers) > 3:
        mult = (f"; the multipliers {', '.join(schema.multipliers)} are searched"
                if schema.multipliers else "")
        raise InputError(f"expected at most three free axes in box {name!r} of design {spec.name} "
                         f"(its region map{mult}), received ranges for {', '.join(free)}; give "
                         "the others a single value")


def gain_key_error(spec: Any, schema: SweepSchema, where: str, keys: Any) -> InputError | None:
    """The one-line error for keys of a gain table ``where`` that are not controller gains
    of the design (``None`` when every key is one).

    >>> from formsync_design.spec.loader import load_spec
    >>> sp = load_spec("pd_consensus")
    >>> print(gain_key_error(sp, SweepSchema.of_design(sp), "[reference]", ["k_p", "eps"]))
    expected the controller gains of design pd_consensus (k_p, k_d) in [reference], received eps (a multiplier of the Lyapunov candidate: every certificate searches it over its declared range 0.001:1)
    """
    bad = [k for k in keys if k not in schema.box]
    if not bad:
        return None
    k = bad[0]
    if k in schema.multipliers:
        why = (f" (a multiplier of the Lyapunov candidate: every certificate searches it over its "
               f"declared range {spec.decl.gain(k).range})")
    elif k == schema.switching:
        why = " (the switching gain: not a box dimension; set it in [montecarlo])"
    else:
        why = ""
    got = k if why else f"unknown {sorted(map(str, bad))}"
    return InputError(f"expected the controller gains of design {spec.name} "
                      f"({', '.join(schema.box)}) in {where}, received {got}{why}")


def default_box(spec: Any, schema: SweepSchema) -> dict[str, Any]:
    """The box ``standard`` of a campaign without ``[[box]]`` (see module docstring).

    >>> from formsync_design.spec.loader import load_spec
    >>> sp = load_spec("pd_consensus")
    >>> default_box(sp, SweepSchema.of_design(sp))
    {'name': 'standard', 'k_p': ['1/10', '2'], 'k_d': ['1/2', '3']}
    """
    out: dict[str, Any] = {"name": "standard"}
    for g in schema.box:
        r = spec.decl.gain(g).range
        if r is not None:
            out[g] = [rational_text(r.lo), rational_text(r.hi)]
        elif g in GAINS:
            out[g] = DEFAULT_BOX[g]
        else:
            raise InputError(f"expected a [[box]] with {g} (design {spec.name} declares no range for "
                             "it), received none")
    return out


def default_reference(spec: Any, schema: SweepSchema) -> dict[str, Any]:
    """The reference point of a campaign without ``[reference]`` (see module docstring).

    >>> from formsync_design.spec.loader import load_spec
    >>> sp = load_spec("pd_consensus")
    >>> default_reference(sp, SweepSchema.of_design(sp))
    {'k_p': '2/5', 'k_d': '8/5'}
    """
    from formsync_design.resources import case_names

    if schema.box == GAINS:
        return dict(DEFAULT_REFERENCE)
    if schema.agent:
        from formsync_design.verify.agentcase import load_agent_case, shipped_agent_case

        path = shipped_agent_case(spec) if is_shipped(spec) else None
        if path is not None:
            have = load_agent_case(path, design=spec).gains.as_dict()
            if all(g in have and not isinstance(have[g], tuple) for g in schema.box):
                return {g: rational_text(parse_number(have[g], f"case {spec.name} {g}"))
                        for g in schema.box}
    elif spec.name in case_names():
        from formsync_design.verify.case import load_case

        case = load_case(spec.name)
        if case.spec == spec.name and is_shipped(spec):
            have = case.gains.as_dict()
            if all(g in have and not isinstance(have[g], tuple) for g in schema.box):
                return {g: rational_text(parse_number(have[g], f"case {spec.name} {g}"))
                        for g in schema.box}
    raise InputError(f"expected a [reference] table (or --ref) with {', '.join(schema.box)} for "
                     f"design {spec.name} (it has no shipped case with scalar gains), received none")


def is_shipped(spec: Any) -> bool:
    """Whether ``spec`` is the shipped design of its name (its content)."""
    from formsync_design.resources import design_names
    from formsync_design.spec.loader import load_design as load_any

    return spec.name in design_names() and bool(load_any(spec.name).key == spec.key)
