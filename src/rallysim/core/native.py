"""What the compiled kernels of one game share: the choice of kernel, Numba, MuJoCo's C
library and NumPy's own LAPACK.

A compiled kernel (``rallysim.core.one_game`` for one SIMPLE game, ``rallysim.core.one_humanlike``
for one HUMAN-LIKE player) restates Python code that a batch also runs, and must give its bits.
So each piece it calls from C is the very code the Python path calls: MuJoCo's library of the
bindings' own version, and LAPACK's ``dgesv`` from the library NumPy's ``linalg.solve`` calls;
and what is compiled anew (sine, cosine, sums) is probed against NumPy before it is used.
Where any of that cannot be had, ``Kernel`` says why and the Python path runs instead, with the
same results.

``KERNEL`` (or the environment variable ``RALLYSIM_KERNEL``) chooses: ``auto`` (the compiled
kernels where they can be had, Python elsewhere), ``python`` or ``compiled`` (refused where
they cannot run).
"""

from __future__ import annotations

import ctypes
import glob
import os
from collections.abc import Callable
from typing import Any

import mujoco

KERNELS = ("auto", "python", "compiled")
KERNEL_VARIABLE = "RALLYSIM_KERNEL"
KERNEL = os.environ.get(KERNEL_VARIABLE, "auto")


class Unavailable(Exception):
    """A compiled kernel cannot be had here (the message says why)."""


def checked_kernel_name(kernel: str | None) -> str:
    """``kernel``, or ``KERNEL`` where it is None; ``ValueError`` for an unknown name."""
    kernel = KERNEL if kernel is None else kernel
    if kernel not in KERNELS:
        raise ValueError(f"unknown kernel {kernel!r} (native.KERNEL or {KERNEL_VARIABLE});"
                         f" valid: {', '.join(map(repr, KERNELS))}")
    return kernel


class Kernel:
    """A compiled kernel of this process, built on first use by ``build`` (called through a
    lambda by its module, so that tests may replace the module's builder): ``function`` (None
    where it cannot be had) and ``why_not`` (why, for errors and test skips)."""

    def __init__(self, build: Callable[[], Callable]) -> None:
        self.build = build
        self.function: Callable | None = None
        self.why_not = "not yet tried"
        self.tried = False

    def get(self) -> Callable | None:
        if not self.tried:
            try:
                self.function, self.why_not = self.build(), ""
            except Unavailable as exc:
                self.why_not = str(exc)
            except Exception as exc:  # a Numba that cannot compile it: Python, same results
                self.why_not = f"compiling failed: {type(exc).__name__}: {exc}"
            self.tried = True  # (not before: an interrupted try is tried again)
        return self.function

    def resolve(self, asked: str) -> Callable | None:
        """The compiled function for a kernel name asked for, or None (Python);
        ``RuntimeError`` where ``compiled`` was asked for and cannot be had."""
        if asked == "python":
            return None
        function = self.get()
        if function is None and asked == "compiled":
            raise RuntimeError(f"the compiled kernel cannot run here: {self.why_not}")
        return function


def numba_module() -> Any:
    try:
        import numba
    except ImportError as exc:
        raise Unavailable(f"Numba cannot be imported (pip install 'rallysim[fast]'): {exc}"
                          ) from None
    return numba


def mujoco_functions(*names: str) -> list[Any]:
    """MuJoCo's C functions ``names``, each taking (model, data) addresses, from the
    ``libmujoco.so`` of the bindings' own version: a struct layout of another would corrupt
    memory without an error. (MuJoCo's errors inside them reach its default handler, which
    ends the process, not the bindings' ``FatalError``.)"""
    version = mujoco.mj_versionString()
    libraries = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
    for path in libraries:
        lib = ctypes.CDLL(path)
        if not hasattr(lib, "mj_versionString"):
            continue
        lib.mj_versionString.restype = ctypes.c_char_p
        if lib.mj_versionString().decode() == version:
            break
    else:
        raise Unavailable(f"no libmujoco.so of MuJoCo {version} beside its Python bindings "
                          f"(found {[os.path.basename(p) for p in libraries]})")
    functions = []
    for name in names:
        function = getattr(lib, name)
        function.argtypes, function.restype = [ctypes.c_void_p, ctypes.c_void_p], None
        functions.append(function)
    return functions


# LAPACK's dgesv with 64-bit integers, as the OpenBLAS of NumPy's wheels names it
DGESV_NAMES = ("scipy_dgesv_64_", "dgesv_64_")


def numpy_dgesv() -> Any:
    """LAPACK's ``dgesv`` (all 8 arguments pointers; integers 64-bit), looked up through
    NumPy's own ``linalg`` extension, whose symbol lookup searches the libraries it links: the
    function ``numpy.linalg.solve`` calls."""
    from numpy.linalg import _umath_linalg

    try:
        lib = ctypes.CDLL(_umath_linalg.__file__)
    except OSError as exc:
        raise Unavailable(f"NumPy's linalg extension cannot be opened: {exc}") from None
    for name in DGESV_NAMES:
        if hasattr(lib, name):
            function = getattr(lib, name)
            function.argtypes, function.restype = [ctypes.c_void_p] * 8, None
            return function
    raise Unavailable("NumPy's LAPACK has no 64-bit-integer dgesv "
                      f"({', '.join(DGESV_NAMES)})")
