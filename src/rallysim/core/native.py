"""What the compiled kernels share: Numba, MuJoCo's C library and NumPy's own LAPACK.

The compiled steps (``rallysim.core.kernels``, and ``rallysim.core.humanlike_step`` for
HUMAN-LIKE players' motion) give the bits of the NumPy code they replaced, which the golden
episodes recorded. So each piece they call from C is the very code NumPy's path called:
MuJoCo's library of the bindings' own version, and LAPACK's ``dgesv`` from the library NumPy's
``linalg.solve`` calls. ``Kernel`` builds a kernel once per process and says why where it
cannot.

The kernels are compiled once per machine and kept in Numba's cache (``jit``): the C functions
are named as symbols in the machine code (``c_function``), found at load time in the libraries
``load_permanently`` loaded, so a later process loads the code instead of compiling it.
"""

from __future__ import annotations

import ctypes
import glob
import hashlib
import os
import types
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np


class Unavailable(Exception):
    """A compiled kernel cannot be had here (the message says why)."""


class Kernel:
    """A compiled kernel of this process, built on first use by ``build`` (called through a
    lambda by its module, so that tests may replace the module's builder)."""

    def __init__(self, build: Callable[[], Any]) -> None:
        self.build = build
        self.function: Any = None
        self.why_not = ""

    def get(self) -> Any:
        """The kernel; ``RuntimeError`` saying why where it cannot be had here."""
        if self.function is None:
            if self.why_not:
                raise RuntimeError(self.why_not)
            try:
                self.function = self.build()
            except Unavailable as exc:
                self.why_not = f"the compiled steps cannot run here: {exc}"
                raise RuntimeError(self.why_not) from None
        return self.function


def numba_module() -> Any:
    try:
        import numba
    except ImportError as exc:
        raise Unavailable(f"Numba cannot be imported (pip install numba): {exc}") from None
    return numba


def jit(function: Callable, **options: Any) -> Any:
    """``numba.njit(**options)(function)``, compiled once per machine: Numba's cache keeps the
    machine code (beside the source in ``__pycache__``, or in the user's cache folder where
    the package's folder is read-only, or under ``NUMBA_CACHE_DIR``), and a later process
    loads it instead of compiling. Numba keys a closure's cache entries on a pickle of the
    functions it closes over, which holds a random identifier per process and so never
    matches; ``_KeyedCache`` keys them on what those functions are instead (``fingerprint``).
    Where Numba's cache cannot be had (no folder to write, another Numba's internals), the
    function compiles in each process, with the same results."""
    numba = numba_module()
    dispatcher = numba.njit(**options)(function)
    cache = _keyed_cache(function)
    if cache is not None:
        dispatcher._cache = cache  # what ``enable_caching`` sets, with our key
    return dispatcher


def _keyed_cache(function: Callable) -> Any:
    """A ``_KeyedCache`` of ``function``, or None where Numba has no cache for it."""
    try:
        from numba.core.caching import FunctionCache
    except ImportError:
        return None
    key = fingerprint(function)

    class _KeyedCache(FunctionCache):
        """Numba's cache of one function, its entries keyed on the signature, the target CPU
        and ``fingerprint`` of the function (Numba's own key hashes only the function's own
        bytecode and pickles what it closes over)."""

        def _index_key(self, sig: Any, codegen: Any) -> tuple:
            return (sig, codegen.magic_tuple(), ("rallysim", key))

    try:
        return _KeyedCache(function)
    except Exception:  # no locator: a source in a zip file, say
        return None


def fingerprint(function: Callable) -> str:
    """A hash of what compiling ``function`` depends on, equal in every process: its bytecode
    and constants, and those of every function, compiled function and intrinsic it closes over
    or reads as a global, with the values of the plain globals it reads (which Numba freezes
    into the machine code). Numba's cache checks the modification time of ``function``'s own
    file; this covers the files of what it calls."""
    return hashlib.sha256(repr(_describe(function, set())).encode()).hexdigest()


def _describe(value: Any, seen: set[int]) -> Any:
    """A description of ``value`` (``fingerprint``) made of plain, printable values."""
    if value is None or isinstance(value, (bool, int, float, complex, str, bytes)):
        return (type(value).__name__, repr(value))
    if isinstance(value, (tuple, list)):
        return (type(value).__name__, tuple(_describe(v, seen) for v in value))
    if isinstance(value, (set, frozenset)):  # (sorted: string hashes differ per process)
        return (type(value).__name__, tuple(sorted(repr(_describe(v, seen)) for v in value)))
    if isinstance(value, types.ModuleType):
        return ("module", value.__name__)
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.shape,
                hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest())
    if isinstance(value, type):  # (with its fields and members in order: a structref's
        # proxy, or a named tuple, lays out its fields by them)
        members = tuple(name for name in vars(value) if not name.startswith("__"))
        return ("type", value.__module__, value.__qualname__,
                tuple(getattr(value, "_fields", ())), members)
    if id(value) in seen:  # (a function that calls itself)
        return ("seen", getattr(value, "__qualname__", type(value).__qualname__))
    seen.add(id(value))
    if isinstance(value, types.FunctionType):
        cells = tuple(_describe(c.cell_contents, seen) for c in value.__closure__ or ())
        names = sorted(_global_names(value.__code__) & value.__globals__.keys())
        reads = tuple((n, _describe(value.__globals__[n], seen)) for n in names)
        return ("function", value.__module__, value.__qualname__, _code(value.__code__), cells,
                reads)
    py_func = getattr(value, "py_func", None)
    if isinstance(py_func, types.FunctionType):  # a Numba dispatcher
        options = sorted((k, repr(v)) for k, v in getattr(value, "targetoptions", {}).items())
        return ("jit", _describe(py_func, seen), tuple(options))
    defn = getattr(value, "_defn", None)
    if isinstance(defn, types.FunctionType):  # a Numba intrinsic
        return ("intrinsic", getattr(value, "_name", ""), _describe(defn, seen))
    # anything else (a NumPy scalar, an enum; or a name read only as an attribute): its repr,
    # where that does not show the object's address (Numba freezes no such object)
    text = repr(value)
    kind = (type(value).__module__, type(value).__qualname__)
    return ("object", kind) if " at 0x" in text else ("value", kind, text)


def _code(code: types.CodeType) -> tuple:
    """What a code object compiles to (not its file or line numbers)."""
    consts = tuple(_code(c) if isinstance(c, types.CodeType) else _describe(c, set())
                   for c in code.co_consts)
    return (code.co_code.hex(), consts, code.co_names, code.co_varnames, code.co_freevars,
            code.co_cellvars, code.co_argcount, code.co_kwonlyargcount, code.co_flags)


def _global_names(code: types.CodeType) -> set[str]:
    """The names ``code`` and the code nested in it may read as globals (and attributes)."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _global_names(const)
    return names


def c_function(symbol: str, n_args: int) -> Any:
    """A Numba intrinsic that calls the C function ``symbol`` (returning nothing) with
    ``n_args`` (2 or 8) pointers, each given as an address (an integer) or as an array (its
    data). The symbol is named in the machine code and found when it is loaded, among the
    libraries loaded with ``load_permanently``: unlike a ``ctypes`` pointer, whose address
    Numba writes into the code, this lets Numba's cache keep the code. An array stays alive
    through the call (it is an argument)."""
    numba_module()
    from llvmlite import ir
    from numba.core import cgutils
    from numba.core import types as nb_types
    from numba.extending import intrinsic

    def typed(args: tuple) -> Any:
        if not all(isinstance(a, (nb_types.Integer, nb_types.Array)) for a in args):
            return None

        def codegen(context: Any, builder: Any, signature: Any, values: Any) -> Any:
            pointer = ir.IntType(8).as_pointer()
            fnty = ir.FunctionType(ir.VoidType(), [pointer] * len(values))
            function = cgutils.get_or_insert_function(builder.module, fnty, symbol)
            pointers = []
            for ty, value in zip(signature.args, values, strict=True):
                if isinstance(ty, nb_types.Array):
                    data = context.make_array(ty)(context, builder, value).data
                    pointers.append(builder.bitcast(data, pointer))
                else:
                    pointers.append(builder.inttoptr(value, pointer))
            builder.call(function, pointers)
            return context.get_dummy_value()

        return nb_types.void(*args), codegen

    # (Numba's intrinsics take no *args: one typer per count)
    def typer2(typingctx: Any, a: Any, b: Any) -> Any:
        return typed((a, b))

    def typer8(typingctx: Any, a: Any, b: Any, c: Any, d: Any, e: Any, f: Any, g: Any, h: Any
               ) -> Any:
        return typed((a, b, c, d, e, f, g, h))

    typer = {2: typer2, 8: typer8}[n_args]
    typer.__name__ = f"call_{symbol}"
    return intrinsic(typer)


def load_permanently(path: str, symbols: dict[str, int]) -> None:
    """Load the shared library ``path`` where machine code from Numba (compiled or loaded from
    its cache) finds its symbols, and check that each of ``symbols`` resolves there to the
    address given (that of the function the Python path calls), not to a namesake elsewhere;
    ``Unavailable`` otherwise."""
    from llvmlite import binding

    binding.load_library_permanently(path)
    for name, address in symbols.items():
        found = binding.address_of_symbol(name)
        if found != address:
            raise Unavailable(f"{name} resolves to another function than the one of "
                              f"{os.path.basename(path)} ({found} != {address})")


def mujoco_functions(*names: str) -> list[Any]:
    """Intrinsics (``c_function``) calling MuJoCo's C functions ``names``, each taking
    (model, data) addresses, from the ``libmujoco.so`` of the bindings' own version: a struct
    layout of another would corrupt memory without an error. (MuJoCo's errors inside them
    reach its default handler, which ends the process, not the bindings' ``FatalError``.)"""
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
    load_permanently(path, {name: _address(getattr(lib, name)) for name in names})
    return [c_function(name, 2) for name in names]


# LAPACK's dgesv with 64-bit integers, as the OpenBLAS of NumPy's wheels names it
DGESV_NAMES = ("scipy_dgesv_64_", "dgesv_64_")


def numpy_dgesv() -> Any:
    """An intrinsic (``c_function``) calling LAPACK's ``dgesv`` (all 8 arguments pointers;
    integers 64-bit): the function ``numpy.linalg.solve`` calls, found through NumPy's own
    ``linalg`` extension, whose symbol lookup searches the libraries it links; the library
    that defines it (NumPy's OpenBLAS) is then loaded for Numba's code."""
    from numpy.linalg import _umath_linalg

    try:
        lib = ctypes.CDLL(_umath_linalg.__file__)
    except OSError as exc:
        raise Unavailable(f"NumPy's linalg extension cannot be opened: {exc}") from None
    for name in DGESV_NAMES:
        if hasattr(lib, name):
            address = _address(getattr(lib, name))
            load_permanently(_library_of(address), {name: address})
            return c_function(name, 8)
    raise Unavailable("NumPy's LAPACK has no 64-bit-integer dgesv "
                      f"({', '.join(DGESV_NAMES)})")


def _address(function: Any) -> int:
    """The address of a ``ctypes`` function."""
    return ctypes.cast(function, ctypes.c_void_p).value


class _DlInfo(ctypes.Structure):
    _fields_ = [("dli_fname", ctypes.c_char_p), ("dli_fbase", ctypes.c_void_p),
                ("dli_sname", ctypes.c_char_p), ("dli_saddr", ctypes.c_void_p)]


def _library_of(address: int) -> str:
    """The path of the shared library that holds ``address`` (``dladdr``)."""
    for name in (None, "libdl.so.2"):  # (glibc before 2.34 has it in libdl only)
        try:
            dladdr = ctypes.CDLL(name).dladdr
            break
        except (OSError, AttributeError):
            continue
    else:
        raise Unavailable("dladdr cannot be had here")
    dladdr.argtypes, dladdr.restype = [ctypes.c_void_p, ctypes.POINTER(_DlInfo)], ctypes.c_int
    info = _DlInfo()
    if not dladdr(address, ctypes.byref(info)) or not info.dli_fname:
        raise Unavailable("the library that holds NumPy's dgesv cannot be found")
    return os.fsdecode(info.dli_fname)
