"""Design files, and the Lagrangian view a design may provide.

A design file (``derivations/NAME.py``) is an agent design (``FORM = "agent"``,
:mod:`formsync_design.spec.agent`), a Lagrangian design (the historical default form), or an
agent design that additionally provides its **Lagrangian view** (liang2016, pd_consensus):

``lagrangian_controller(view: ControllerView)`` (``controller(view)`` in a Lagrangian file)
    the torque ``u_i`` as a 3x1 expression in the opaque model matrices ``view.A``,
    ``view.B``, ``view.Q`` (3x3 ``MatrixSymbol``), ``view.qd`` (``q_i'``), ``view.s``
    (``sum_{j in G_i} (q_i - q_j)``), the declared gains and a switching term
    ``view.sw(arg)`` (sgn, or a smooth substitute chosen at simulation time);
``lyapunov(view: LyapunovView)``
    the term ``V_i`` of ``V = sum_i V_i`` in explicit 3-vectors ``view.qd`` and
    ``view.edges`` (``q_i - q_j`` for the ``m`` neighbours), ``view.s = sum(view.edges)``.

:func:`load_design` gives the design (an agent design carries its view as ``.lagrangian``);
:func:`load_spec` the Lagrangian view (:class:`Spec`, the input of the derive, certify and
classic simulation stages).  A :class:`Spec` is a value keyed by :attr:`Spec.key`, the SHA-256
digest of the file's content (or of the functions, :meth:`Spec.from_functions`), never by a
path.  Every function is validated when the file is loaded, by calling it on the views: a
malformed file is a one-line :class:`~formsync_design.errors.DerivationError` naming the file,
the function and what was expected, before any command creates output.
"""

from __future__ import annotations

import hashlib
import inspect
import itertools
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError, InputError
from formsync_design.spec.declarations import (
    CLASSIC,
    Declarations,
    parse_declarations,
)
from formsync_design.spec.lagrangian_view import ControllerView, LyapunovView

__all__ = [
    "agent_design_of",
    "lagrangian_view",
    "LAGRANGIAN_CONTROLLER",
    "Spec",
    "load_spec",
    "load_design",
    "FORMS",
    "AGENT_COMMANDS",
    "validate_spec",
    "default_spec_path",
    "gain_symbols",
    "controller_expression",
]


def gain_symbols(spec: Any = None) -> tuple[sp.Symbol, ...]:
    """The gain symbols of the families (positive reals), in box order.

    ``spec=None``: the classic gains ``(K_o, K_q, beta)``; a :class:`Spec`: its
    controller gains then its multipliers.

    >>> gain_symbols()
    (K_o, K_q, beta)
    """
    decl = spec.decl if spec is not None else CLASSIC
    return decl.family_symbols()


@dataclass(frozen=True)
class Spec:
    """A controller + Lyapunov-candidate specification (a value).

    Attributes
    ----------
    name, title : str
        Short id and one-line description.
    path : str
        The file it was loaded from (equal to ``source``), or ``"<python>"``.
    controller, lyapunov : callable
        The two functions of the module docstring.
    key : str
        SHA-256 hex digest of the content: a file's bytes; for
        :meth:`from_functions`, the name, the functions' source text and the
        expressions they return on the views (or, without source, a
        per-object unique token).  Caches are keyed by it.
    source : str
        The file path, or ``"<python>"``.

    Examples
    --------
    >>> spec = load_spec()
    >>> spec.name, len(spec.key), spec.source == spec.path
    ('liang2016', 64, True)
    """

    name: str
    title: str
    path: str
    controller: Callable[[ControllerView], Any]
    lyapunov: Callable[[LyapunovView], Any]
    key: str = ""
    source: str = ""
    decl: Declarations = CLASSIC

    @property
    def gains(self) -> tuple[str, ...]:
        """Names of the box dimensions (controller gains, then multipliers)."""
        return self.decl.family_gains

    @property
    def representation(self) -> str:
        return self.decl.representation

    @classmethod
    def from_functions(
        cls,
        controller: Callable[[ControllerView], Any],
        lyapunov: Callable[[LyapunovView], Any],
        *,
        name: str = "custom",
        title: str | None = None,
        gains: Any = None,
        representation: str = "quaternion",
        graphs: Any = None,
        sampling: str = "continuous",
    ) -> Spec:
        """A specification from two Python callables (e.g. written in a notebook).

        The functions are validated like a file's (see :func:`validate_spec`).

        Examples
        --------
        >>> def controller(v):
        ...     return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s
        ...                       - v.K_v * v.A * v.sw(v.qd + v.beta * v.s))
        >>> def lyapunov(v):
        ...     return v.qd.dot(v.qd) / 2 + (v.K_q + v.beta * v.K_o) / 4 * sum(
        ...         (e.dot(e) for e in v.edges), 0) + v.beta * sum((e.dot(v.qd) for e in v.edges), 0)
        >>> spec = Spec.from_functions(controller, lyapunov, name="inline")
        >>> spec.source, spec.name, len(spec.key)
        ('<python>', 'inline', 64)
        >>> spec.key == Spec.from_functions(controller, lyapunov, name="inline").key
        True
        """
        for fn, f in (("controller", controller), ("lyapunov", lyapunov)):
            if not callable(f):
                raise DerivationError(
                    f"<python>: expected {fn} to be a function {fn}(view), received "
                    f"{type(f).__name__}"
                )
        attrs: dict[str, Any] = {"REPRESENTATION": representation, "SAMPLING": sampling}
        if gains is not None:
            attrs["GAINS"] = gains
        if graphs is not None:
            attrs["GRAPHS"] = graphs
        decl = parse_declarations(attrs, PYTHON_SOURCE)
        outputs = validate_spec(controller, lyapunov, "<python>", decl)
        h = hashlib.sha256()
        h.update(f"name:{name}\n".encode())
        if decl != CLASSIC:
            h.update(repr(decl.to_dict()).encode())
        for f in (controller, lyapunov):
            h.update(_source_token(f).encode())
            h.update(b"\n")
        h.update(outputs.encode())
        return cls(
            name=str(name),
            title=str(title if title is not None else name),
            path=PYTHON_SOURCE,
            controller=controller,
            lyapunov=lyapunov,
            key=h.hexdigest(),
            source=PYTHON_SOURCE,
            decl=decl,
        )


#: ``Spec.source`` of a specification built in Python.
PYTHON_SOURCE = "<python>"

_tokens: weakref.WeakKeyDictionary[Any, str] = weakref.WeakKeyDictionary()
_token_counter = itertools.count()


def _source_token(f: Callable[..., Any]) -> str:
    """The source text of ``f`` plus its closure values, or a per-object unique token."""
    try:
        text = inspect.getsource(f)
    except (OSError, TypeError):
        try:
            tok = _tokens.get(f)
            if tok is None:
                tok = _tokens[f] = f"token:{next(_token_counter)}:{id(f)}"
        except TypeError:  # not weak-referenceable
            tok = f"token:{next(_token_counter)}:{id(f)}"
        return tok
    cells = getattr(f, "__closure__", None) or ()
    vals = []
    for c in cells:
        try:
            vals.append(repr(c.cell_contents))
        except ValueError:  # empty cell
            vals.append("<empty>")
    return text + "\nclosure:" + "|".join(vals)


def _one_line(e: BaseException) -> str:
    msg = " ".join(str(e).split())
    return f"{type(e).__name__}: {msg}" if msg else type(e).__name__


def _call(fn_name: str, f: Callable[[Any], Any], view: Any, where: str) -> Any:
    """Call a user's function on a view; any failure is a one-line DerivationError."""
    what = "a 3x1 matrix expression" if fn_name == "controller" else "a scalar expression"
    try:
        return f(view)
    except DerivationError as e:
        raise DerivationError(f"{where}: {fn_name}(view): {e}") from None
    except AttributeError as e:
        attr = getattr(e, "name", None)
        if getattr(e, "obj", None) is view and attr:
            raise DerivationError(
                f"{where}: {fn_name}(view): expected an attribute of the view "
                f"({_view_attributes(view)}), received view.{attr}"
            ) from None
        raise DerivationError(
            f"{where}: {fn_name}(view): expected {what}, the function raised {_one_line(e)}"
        ) from None
    except NameError as e:
        raise DerivationError(
            f"{where}: {fn_name}(view): expected only the view's names and symbols, "
            f"received the unknown name {getattr(e, 'name', None) or _one_line(e)}"
        ) from None
    except RecursionError:
        raise DerivationError(
            f"{where}: {fn_name}(view): expected {what}, the function recursed without end"
        ) from None
    except Exception as e:  # a user's function: report, don't crash
        raise DerivationError(
            f"{where}: {fn_name}(view): expected {what}, the function raised {_one_line(e)}"
        ) from None


def _view_attributes(view: Any) -> str:
    return str(view.attributes())


def validate_spec(
    controller: Callable[[ControllerView], Any],
    lyapunov: Callable[[LyapunovView], Any],
    where: str,
    decl: Declarations = CLASSIC,
) -> str:
    """Call both functions on the views and check what they return.

    Parameters
    ----------
    controller, lyapunov : callable
        The specification's functions.
    where : str
        The file (or ``"<python>"``) named in error messages.
    decl : Declarations
        The design's declarations (gains the views provide); default: the classic gains.

    Returns
    -------
    str
        A canonical text (``sympy.srepr``) of what the functions returned,
        usable as part of a content key.

    Raises
    ------
    DerivationError
        One line naming ``where``, the function and what was expected, if a
        function raises, uses an attribute of the view that does not exist or
        an unknown symbol, or returns the wrong shape.

    Examples
    --------
    >>> validate_spec(lambda v: v.qd, lambda v: v.qd.dot(v.qd), "demo")[:10]
    'MatrixSymb'
    >>> validate_spec(lambda v: v.A, lambda v: 0, "demo")
    Traceback (most recent call last):
    ...
    formsync_design.errors.DerivationError: demo: controller(view): expected a 3x1 matrix expression, received shape (3, 3)
    """
    v = ControllerView(decl)
    u = _call("controller", controller, v, where)
    shape = getattr(u, "shape", None)
    if shape != (3, 1) or not isinstance(u, (sp.MatrixBase, sp.MatrixExpr)):
        got = f"shape {tuple(shape)}" if shape is not None else f"a {type(u).__name__}"
        raise DerivationError(
            f"{where}: controller(view): expected a 3x1 matrix expression, received {got}"
        )
    extra = {str(x) for x in u.free_symbols} - {str(x) for x in v.symbols()}
    if extra:
        raise DerivationError(
            f"{where}: controller(view): expected only the view's symbols "
            f"({_view_attributes(v)}), received unknown symbols {sorted(extra)}"
        )
    parts = [sp.srepr(u)]
    for m in (1, 2):
        lv = LyapunovView(m, decl)
        V = _call("lyapunov", lyapunov, lv, where)
        try:
            Vs = sp.sympify(V)
        except (sp.SympifyError, TypeError, ValueError):
            raise DerivationError(
                f"{where}: lyapunov(view): expected a scalar expression, received a "
                f"{type(V).__name__}"
            ) from None
        if isinstance(Vs, (sp.MatrixBase, sp.MatrixExpr)):
            if Vs.shape == (1, 1):
                Vs = Vs[0, 0]
            else:
                raise DerivationError(
                    f"{where}: lyapunov(view): expected a scalar expression, received shape "
                    f"{tuple(Vs.shape)}"
                )
        if not isinstance(Vs, sp.Expr):
            raise DerivationError(
                f"{where}: lyapunov(view): expected a scalar expression, received a "
                f"{type(V).__name__}"
            )
        extra = {str(x) for x in Vs.free_symbols - lv.symbols()}
        if extra:
            raise DerivationError(
                f"{where}: lyapunov(view): expected V_i in view.qd, view.edges and the gains "
                f"{', '.join(lv.gains)} only, received unknown symbols {sorted(extra)}"
            )
        parts.append(sp.srepr(Vs))
    return "\n".join(parts)


def controller_expression(spec: Spec) -> tuple[ControllerView, Any]:
    """The view given to ``spec.controller`` and the 3x1 expression it returns.

    >>> v, u = controller_expression(load_spec())
    >>> u.shape, len(v.switch_arguments)
    ((3, 1), 1)
    """
    view = ControllerView(spec.decl)
    u = spec.controller(view)
    if getattr(u, "shape", None) != (3, 1):
        raise DerivationError(
            f"expected controller() to return a 3x1 matrix expression, received shape "
            f"{getattr(u, 'shape', None)}"
        )
    return view, u


def default_spec_path() -> Path:
    """Path of the paper's specification, ``derivations/liang2016.py``.

    Shipped inside the package as ``formsync_design.derivations``.

    >>> default_spec_path().name
    'liang2016.py'
    """
    from formsync_design.resources import design_file

    return design_file("liang2016")


#: Design forms: ``lagrangian`` (this module's :class:`Spec`) and ``agent``
#: (:class:`~formsync_design.spec.agent.AgentDesign`).
FORMS: tuple[str, ...] = ("lagrangian", "agent")

#: Loaded files by (resolved path, content digest): a file loaded twice gives the same value.
_LOADED: dict[tuple[str, str], Spec] = {}


def _load_file(p: Path, sha256: str | None = None) -> Spec:
    from formsync_design.spec import trust

    where = str(p)
    if not p.exists():
        raise InputError(f"expected a specification .py file, received {where!r} (no such file)")
    if not p.is_file():
        raise InputError(f"expected a specification .py file, received {where!r} (not a file)")
    try:
        data = p.read_bytes()
    except OSError as e:
        raise InputError(
            f"expected a readable specification file, received {where!r} ({e.strerror or e})"
        ) from None
    key = hashlib.sha256(data).hexdigest()
    want = sha256 or trust.pinned_digest(p)
    if want is not None and key != want:
        raise InputError(f"expected the design file {where} with the content trusted (sha256 "
                         f"{want}), received content with sha256 {key} (the file changed)")
    shipped = trust.is_shipped_file(p)
    if not shipped:
        trust.note_loaded(where, key)
    cache_key = (str(p.resolve()), key)
    if cache_key in _LOADED:
        return _LOADED[cache_key]
    if shipped:
        return _load_code(p, data, key)
    from formsync_design.spec.contain import contained

    with contained(where, "loading the design and the first evaluation of its laws"):
        return _load_code(p, data, key)


def _load_code(p: Path, data: bytes, key: str) -> Spec:
    """Compile, run and validate a design file's content (``key``: its sha256)."""
    where = str(p)
    cache_key = (str(p.resolve()), key)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise DerivationError(
            f"{where}: expected a UTF-8 Python specification, received non-UTF-8 bytes "
            f"(byte {e.start})"
        ) from None
    if "\x00" in text:
        raise DerivationError(
            f"{where}: expected a UTF-8 Python specification, received a binary file (NUL byte)"
        )
    try:
        code = compile(text, where, "exec")
    except SyntaxError as e:
        raise DerivationError(
            f"{where}: expected valid Python, received a syntax error at line {e.lineno}: {e.msg}"
        ) from None
    except (ValueError, MemoryError, RecursionError) as e:
        raise DerivationError(f"{where}: expected valid Python, received {_one_line(e)}") from None
    mod = ModuleType(f"_formsync_spec_{key[:16]}")
    mod.__file__ = where
    try:
        exec(code, mod.__dict__)
    except Exception as e:  # a user's file: report, don't crash (other escapes: spec.contain)
        raise DerivationError(
            f"{where}: expected the specification module to import, it raised {_one_line(e)}"
        ) from None
    form = mod.__dict__.get("FORM", "lagrangian")
    if form not in FORMS:
        raise DerivationError(f"{where}: FORM: expected one of {list(FORMS)}, received {form!r}")
    if form == "agent":
        from dataclasses import replace

        from formsync_design.spec.agent import agent_design_from_module

        agent = agent_design_from_module(mod, where, key, p.stem)
        if LAGRANGIAN_CONTROLLER in mod.__dict__:
            agent = replace(agent, lagrangian=_lagrangian_view(mod, where, key, p.stem))
        _LOADED[cache_key] = agent  # type: ignore[assignment]
        return agent  # type: ignore[return-value]
    for fn in ("controller", "lyapunov"):
        if not callable(getattr(mod, fn, None)):
            got = "none" if not hasattr(mod, fn) else f"a {type(getattr(mod, fn)).__name__}"
            raise DerivationError(f"{where}: expected a function {fn}(view), received {got}")
    decl = parse_declarations(mod.__dict__, where)
    validate_spec(mod.controller, mod.lyapunov, where, decl)
    spec = Spec(
        name=str(getattr(mod, "NAME", p.stem)),
        title=str(getattr(mod, "TITLE", p.stem)),
        path=where,
        controller=mod.controller,
        lyapunov=mod.lyapunov,
        key=key,
        source=where,
        decl=decl,
    )
    _LOADED[cache_key] = spec
    return spec


#: The function of an agent design file that gives its Lagrangian view (with ``lyapunov``).
LAGRANGIAN_CONTROLLER = "lagrangian_controller"


def _lagrangian_view(mod: ModuleType, where: str, key: str, stem: str) -> Spec:
    """The Lagrangian view of an agent design file: ``lagrangian_controller(view)`` and
    ``lyapunov(view)`` on the design's one ``GAINS`` table, validated like a Lagrangian
    design's (same name, title and content key as the file)."""
    for fn in (LAGRANGIAN_CONTROLLER, "lyapunov"):
        if not callable(getattr(mod, fn, None)):
            got = "none" if not hasattr(mod, fn) else f"a {type(getattr(mod, fn)).__name__}"
            raise DerivationError(f"{where}: expected a function {fn}(view) for the design's "
                                  f"Lagrangian view, received {got}")
    decl = parse_declarations(mod.__dict__, where)
    ctrl = getattr(mod, LAGRANGIAN_CONTROLLER)
    validate_spec(ctrl, mod.lyapunov, where, decl)
    return Spec(name=str(getattr(mod, "NAME", stem)), title=str(getattr(mod, "TITLE", stem)),
                path=where, controller=ctrl, lyapunov=mod.lyapunov, key=key, source=where,
                decl=decl)


def lagrangian_view(design: Any) -> Spec | None:
    """The Lagrangian view of a loaded design: a :class:`Spec` itself, an agent design's
    :attr:`~formsync_design.spec.agent.AgentDesign.lagrangian` (``None`` if it has none).

    >>> lagrangian_view(load_design("liang2016")).controller.__name__
    'lagrangian_controller'
    >>> lagrangian_view(load_design("ma_so3")) is None
    True
    """
    if isinstance(design, Spec):
        return design
    return getattr(design, "lagrangian", None)


def load_spec(spec: Spec | str | Path | None = None, *, sha256: str | None = None) -> Spec:
    """The Lagrangian view of the design ``spec`` resolves to (see :func:`load_design`): a
    Lagrangian design itself, or the view an agent design provides; an agent design without
    one is a one-line :class:`DerivationError` naming the commands that run it.

    >>> load_spec("liang2016").name, load_design("liang2016").form
    ('liang2016', 'agent')
    >>> load_spec("liang2016") is load_design("liang2016").lagrangian
    True
    """
    d = load_design(spec, sha256=sha256)
    if lagrangian_view(d) is not None:
        return lagrangian_view(d)  # type: ignore[return-value]
    if getattr(d, "form", "lagrangian") == "agent":
        raise DerivationError(
            f"{d.path}: FORM: expected a Lagrangian design (controller(view) in A, B, Q) here, "
            f"received the agent design {d.name!r} (REPRESENTATION {d.representation!r}); "
            f"agent designs run with {', '.join(AGENT_COMMANDS)}"
        )
    return d


#: The commands that take agent designs (the others need a Lagrangian design).
AGENT_COMMANDS: tuple[str, ...] = ("formsync derive", "formsync simulate", "formsync certify",
                                  "formsync region", "formsync design", "formsync montecarlo",
                                  "formsync verify", "formsync sweep")


def load_design(spec: Any = None, *, sha256: str | None = None) -> Any:
    """The design ``spec`` resolves to: a Lagrangian :class:`Spec` or an agent design
    (:class:`~formsync_design.spec.agent.AgentDesign`, with its Lagrangian view if it has one).

    ``spec``: ``None`` (the paper's design, ``liang2016``), a shipped design's name (see
    :func:`~formsync_design.resources.design_names`: always the shipped file, whatever files
    the current folder holds), a path (that file, loaded and validated: the caller named it,
    see :mod:`formsync_design.spec.trust`) or a loaded design (returned unchanged).
    ``sha256``: load the file only if its content has this digest (else an
    :class:`InputError`).  A file that is not shipped is loaded under the rules of
    :mod:`formsync_design.spec.contain` and recorded (:func:`~formsync_design.spec.trust.design_code`).  A missing or unreadable file, or another type,
    is an :class:`InputError`; a malformed design a one-line :class:`DerivationError` naming
    the file, the function and what was expected (see :func:`validate_spec`).

    Examples
    --------
    >>> load_design("pd_consensus").gains
    ('k_p', 'k_d', 'eps')
    >>> spec = load_spec()
    >>> spec.name, load_spec(spec) is spec, load_spec(spec.path).key == spec.key
    ('liang2016', True, True)
    >>> load_spec("liang2016") is spec
    True
    """
    if isinstance(spec, Spec) or getattr(spec, "form", None) == "agent":
        return spec
    if spec is None:
        return _load_file(default_spec_path())
    if isinstance(spec, (str, Path)):
        if isinstance(spec, str) and not spec.strip():
            raise InputError("expected a specification .py file, received an empty string")
        if isinstance(spec, str) and spec.isidentifier():
            from formsync_design.resources import design_file, design_names

            names = design_names()
            if spec in names:
                return _load_file(design_file(spec), sha256)
            if not Path(spec).exists():
                raise InputError(
                    f"expected a design name ({', '.join(names)}) or a .py file, received {spec!r}"
                )
        return _load_file(Path(spec), sha256)
    raise InputError(
        "expected a specification (a Spec, a .py file path, or None), received a "
        f"{type(spec).__name__}"
    )


def agent_design_of(spec: Any) -> Any:
    """The agent design a stage that takes both forms (simulate, conditions, the derivation
    report, the Monte-Carlo) runs for ``spec``, else ``None``: that stage's Lagrangian path
    (a Lagrangian design, the default, or the *name or file* of a design with a Lagrangian
    view; a loaded agent design is run as given).

    >>> agent_design_of("ma_so3").name, agent_design_of("pd_consensus"), agent_design_of(None)
    ('ma_so3', None, None)
    >>> agent_design_of(load_design("pd_consensus")).name
    'pd_consensus'
    """
    if spec is None:
        return None
    if getattr(spec, "form", None) == "agent":
        return spec
    if getattr(spec, "form", None) is not None or not isinstance(spec, (str, Path)):
        return None
    d = load_design(spec)
    return d if getattr(d, "form", None) == "agent" and lagrangian_view(d) is None else None
