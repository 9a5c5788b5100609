"""Whole-horizon compiled kernels: one shared object per design, switch and inverse.

The per-spacecraft closed loop (:func:`~formsync_design.sim.kernels.agent_functions`,
built from the derivation through the bridge) is generated to C by CasADi and compiled
together with the driver of :mod:`formsync_design.sim.native_c` (RK4 or DOPRI5 over the
whole horizon, events located on the interpolant, output decimated inside, batches of
runs on threads).  Python calls it once per run (:meth:`NativeKernel.run`) or once per
batch of runs (:meth:`NativeKernel.batch`); nothing happens per step in Python.

The object does not depend on the number of spacecraft or on the graph (the driver
loops over spacecraft and the Laplacian's nonzeros), so one compilation serves every
formation of a design.  It is cached in :func:`~formsync_design.sim.ccompile.cache_dir`
``/kernels`` under a digest of the specification's content key, the switch and inverse,
and the code that generates the source (:func:`generator_digest`: these modules, the
model's, the bridge's and the specification loader's, with the versions of
formsync-design, SymPy and CasADi), so a warm run loads the object without deriving
the model in SymPy or generating C, and a changed design or generator builds anew.
"""

from __future__ import annotations

import ctypes
import functools
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from formsync_design.errors import CompilerError, SimulationError
from formsync_design.sim.ccompile import (
    build_shared,
    c_compiler,
    code_digest,
    compile_enabled,
    generated_source,
    warn_no_compiler,
)
from formsync_design.sim.kernels import NTRIG, agent_functions, gain_size, param_layout
from formsync_design.sim.native_c import CFG, DRIVER_SOURCE, EVENTS, INFO, LAYOUT, SUMMARY
from formsync_design.spec.loader import Spec

__all__ = ["NativeKernel", "RunOutput", "get_native", "clear_native_cache", "native_source",
           "generator_digest", "native_key", "layout_offsets", "METHODS", "SWITCH_EVENTS"]

#: The driver's integrators (``cfg[method]``).
METHODS = {"rk4": 0, "dopri5": 1}

#: Switching-event kind per switch: crossings of the boundary layer ``|tau| = phi``
#: (``sat``), sign changes of ``tau`` (``sgn``), none for the smooth ``tanh``.
SWITCH_EVENTS = {"sat": 1, "sgn": 2, "tanh": 0}

_D = ctypes.POINTER(ctypes.c_double)
_L = ctypes.POINTER(ctypes.c_long)


def layout_offsets(n: int, ngains: int) -> np.ndarray:
    """Start of every parameter block of :func:`~formsync_design.sim.kernels.param_layout`
    in the driver's order (:data:`~formsync_design.sim.native_c.LAYOUT`).

    >>> layout_offsets(2, 3).tolist()[:4]
    [0, 3, 5, 6]
    """
    lay = param_layout(n, ngains)
    return np.array([lay[name].start for name in LAYOUT], dtype=np.int64)


def native_source(spec: Spec, switch: str, inverse: str) -> str:
    """The C source of the kernel: CasADi's code of the per-spacecraft functions, then the
    driver (with the work sizes it needs)."""
    fns = agent_functions(spec, switch, inverse)
    cg = ca.CodeGenerator("fsk.c", {"with_header": False})
    for fn in fns:
        cg.add(fn)
    gen = generated_source(cg, "fsk.c", "the simulation kernel fsd_kernel")
    sizes = {k: max(getattr(fn, k)() for fn in fns) for k in ("sz_arg", "sz_res", "sz_iw", "sz_w")}
    head = "\n".join([
        f"#define FSD_NG {gain_size(spec)}",
        f"#define FSD_NTRIG {NTRIG}",
        f"#define FSD_SZ_ARG {max(sizes['sz_arg'], 12)}",
        f"#define FSD_SZ_RES {max(sizes['sz_res'], 4)}",
        f"#define FSD_SZ_IW {sizes['sz_iw']}",
        f"#define FSD_SZ_W {sizes['sz_w']}",
    ])
    return gen + "\n" + head + "\n" + DRIVER_SOURCE


#: The package folders and modules whose code determines the generated source (paths
#: relative to the package): the model, the bridge, the specification loader and views,
#: the kernels' closed loop and parameter layout, this module and the C driver.
GENERATOR_CODE = ("models", "spec", "sim/bridge.py", "sim/kernels.py", "sim/layout.py",
                  "sim/formation.py", "sim/metrics.py", "sim/native.py", "sim/native_c.py",
                  "sim/ccompile.py", "derive", "gains.py", "safeexpr.py")


@functools.cache
def generator_digest() -> str:
    """SHA-256 of the code that generates a kernel's source (:data:`GENERATOR_CODE`) and of
    the versions of formsync-design, SymPy and CasADi: part of every kernel's cache key,
    so an edited generator never loads an object built by the old one.

    >>> len(generator_digest())
    64
    """
    return code_digest(GENERATOR_CODE)


def native_key(spec: Spec, switch: str, inverse: str) -> str:
    """The cache key of the compiled kernel of ``spec`` (its content key), ``switch`` and
    ``inverse``, and the generator (:func:`generator_digest`).

    >>> from formsync_design.spec.loader import load_spec
    >>> native_key(load_spec(None), "sat", "E") != native_key(load_spec(None), "sgn", "E")
    True
    """
    return "|".join(["fsd_kernel", spec.key, switch, inverse, generator_digest()])


def _ptr(a: np.ndarray) -> Any:
    return a.ctypes.data_as(_L if a.dtype == np.int64 else _D)


@dataclass(frozen=True)
class RunOutput:
    """What one run of the driver returns (arrays on the output grid, rows ``0..kdone``)."""

    X: np.ndarray
    U: np.ndarray
    MET: np.ndarray
    MINQ: np.ndarray
    info: dict[str, float]
    events: dict[str, float]


class NativeKernel:
    """The loaded shared object of one design / switch / inverse (see the module docstring)."""

    def __init__(self, lib: ctypes.CDLL, so: Path, spec_key: str, switch: str, inverse: str,
                 ngains: int, build_seconds: float) -> None:
        self.lib = lib
        self.path = so
        self.spec_key = spec_key
        self.switch = switch
        self.inverse = inverse
        self.ngains = ngains
        self.build_seconds = build_seconds
        lib.fsd_run.restype = ctypes.c_int
        lib.fsd_run.argtypes = [ctypes.c_int, _D, _L, _D, _D, ctypes.c_double, ctypes.c_long,
                                _D, _D, _D, _D, _D, _D]
        lib.fsd_batch.restype = ctypes.c_int
        lib.fsd_batch.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_long, _D, _L, _D, _D,
                                  ctypes.c_long, _D, ctypes.c_int]
        sizes = np.zeros(5, dtype=np.int64)
        lib.fsd_sizes(_ptr(sizes))
        expect = (16, len(INFO), len(SUMMARY), len(EVENTS), len(LAYOUT))
        if tuple(int(v) for v in sizes) != expect or len(CFG) != 16:
            raise CompilerError(f"the compiled kernel {so} does not match this version of "
                                "formsync-design (delete it to rebuild)")

    def run(self, n: int, p: np.ndarray, cfg: np.ndarray, x0: np.ndarray, t0: float,
            K: int) -> RunOutput:
        """Integrate ``K`` output intervals from ``(t0, x0)`` (one call, the whole horizon)."""
        nx = 7 * n
        off = layout_offsets(n, self.ngains)
        p = np.ascontiguousarray(p, dtype=float)
        cfg = np.ascontiguousarray(cfg, dtype=float)
        x0 = np.ascontiguousarray(x0, dtype=float)
        X = np.empty((K + 1, nx))
        U = np.empty((K + 1, 3 * n))
        MET = np.empty((K + 1, 2))
        MINQ = np.empty(n)
        info = np.empty(len(INFO))
        ev = np.empty(len(EVENTS))
        rc = self.lib.fsd_run(n, _ptr(p), _ptr(off), _ptr(cfg), _ptr(x0), float(t0), int(K),
                              _ptr(X), _ptr(U), _ptr(MET), _ptr(MINQ), _ptr(info), _ptr(ev))
        if rc != 0:
            raise SimulationError(f"expected the compiled kernel to run {n} spacecraft, it ran "
                                  "out of memory; use fewer spacecraft or output points")
        k = int(info[INFO.index("kdone")])
        return RunOutput(X[: k + 1], U[: k + 1], MET[: k + 1], MINQ,
                         dict(zip(INFO, (float(v) for v in info), strict=True)),
                         dict(zip(EVENTS, (float(v) for v in ev), strict=True)))

    def batch(self, n: int, P: np.ndarray, cfg: np.ndarray, X0: np.ndarray, K: int,
              threads: int) -> np.ndarray:
        """``B`` runs (rows of ``P`` and ``X0``) spread over ``threads`` threads; returns the
        per-run summaries ``(B, len(SUMMARY))`` reduced in the kernel."""
        P = np.ascontiguousarray(P, dtype=float)
        X0 = np.ascontiguousarray(X0, dtype=float)
        cfg = np.ascontiguousarray(cfg, dtype=float)
        off = layout_offsets(n, self.ngains)
        B = P.shape[0]
        S = np.empty((B, len(SUMMARY)))
        rc = self.lib.fsd_batch(B, n, P.shape[1], _ptr(P), _ptr(off), _ptr(cfg), _ptr(X0), int(K),
                                _ptr(S), int(threads))
        if rc != 0:
            raise SimulationError(f"expected the compiled kernel to run a batch of {B} runs, it "
                                  "ran out of memory or threads; use a smaller batch")
        return S


_NATIVE: dict[tuple[Any, ...], NativeKernel | None] = {}


def get_native(spec: Spec, switch: str, inverse: str, compile: bool = True) -> NativeKernel | None:
    """The compiled whole-horizon kernel of ``spec`` (cached in memory and on disk), or
    None when compilation is off (``compile=False``, ``FORMSYNC_NO_COMPILE``) or no C
    compiler exists (then with a :class:`RuntimeWarning`): the caller falls back to
    CasADi's virtual machine.

    Raises :class:`~formsync_design.errors.CompilerError` when the compiler fails.
    """
    if not (compile and compile_enabled()):
        return None
    key = (spec.key, switch, inverse)
    if key in _NATIVE:
        return _NATIVE[key]
    cc = c_compiler()
    if cc is None:
        warn_no_compiler(stacklevel=4)
        _NATIVE[key] = None
        return None
    t0 = time.perf_counter()
    so = build_shared("fsd_kernel", lambda: native_source(spec, switch, inverse),
                      native_key(spec, switch, inverse), cc, libs=("-lm", "-pthread"))
    try:
        lib = ctypes.CDLL(str(so))
    except OSError as e:
        raise CompilerError(f"loading the compiled kernel {so} failed ({' '.join(str(e).split())[:200]}); "
                            "delete it to rebuild, or set FORMSYNC_NO_COMPILE=1") from None
    nk = NativeKernel(lib, so, spec.key, switch, inverse, gain_size(spec), time.perf_counter() - t0)
    _NATIVE[key] = nk
    return nk


def clear_native_cache() -> None:
    """Forget the kernels held in memory (the compiled files on disk stay)."""
    _NATIVE.clear()
