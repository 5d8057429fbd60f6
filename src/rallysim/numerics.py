"""Which floating-point code a process runs, and how to pin it so that results agree across CPUs.

NumPy, OpenBLAS and torch each pick SIMD kernels for the CPU they run on, and those kernels round
differently: the same seed gives other bits on an Intel CPU with AVX-512 than on an AMD one with
AVX2 (docs/numerics.md). ``PINNED`` names one choice that every x86-64 CPU with AVX2 can run;
with it in a process's environment *before Python starts* (NumPy reads its variable when it is
imported), the simulator's episodes and the MLP policies' actions give the same bits on any such
CPU. The test suite runs under it (tests/conftest.py); ``describe`` records what a run used.

This module imports neither NumPy nor torch at import time, so that a caller can set the
environment first.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping
from typing import Any


def _numpy_avx512_names() -> tuple[str, ...]:
    """NumPy's names of its AVX-512 dispatch targets (read from its version, not an import):
    disabled, NumPy runs its AVX2 code. NumPy 2.4 grouped them as X86_V4."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        major, minor = (int(x) for x in version("numpy").split(".")[:2])
    except (PackageNotFoundError, ValueError):
        major, minor = 2, 4
    if (major, minor) >= (2, 4):
        return ("X86_V4", "AVX512_ICL", "AVX512_SPR")
    return ("AVX512F", "AVX512CD", "AVX512_KNL", "AVX512_KNM", "AVX512_SKX", "AVX512_CLX",
            "AVX512_CNL", "AVX512_ICL", "AVX512_SPR")


NUMPY_AVX512 = _numpy_avx512_names()
PINNED: dict[str, str] = {
    "NPY_DISABLE_CPU_FEATURES": " ".join(NUMPY_AVX512),
    # OpenBLAS's Haswell kernels (AVX2 + FMA) for its BLAS and LAPACK; Zen runs the same ones
    "OPENBLAS_CORETYPE": "Haswell",
    # torch's ATen kernels at AVX2 (the same compiled code on any AVX2 CPU)
    "ATEN_CPU_CAPABILITY": "avx2",
}
# A candidate for training runs that repeat bit for bit across CPU vendors: ``PINNED`` and MKL
# (torch's SGEMM and the QR of SB3's initialisation) on its cross-vendor branch. MKL takes its
# other branches (MKL_CBWR=AVX2, ...) only on Intel CPUs and runs its automatic choice on
# others, so only COMPATIBLE names the same code on both. It costs about 30 % of the low stage's
# speed; whether it gives equal bits on an Intel and an AMD CPU is not yet shown
# (benchmarks/numerics_fingerprint.py, docs/numerics.md).
TRAINING_CANDIDATE: dict[str, str] = {**PINNED, "MKL_CBWR": "COMPATIBLE"}
# every variable that changes which kernels run (recorded by ``describe``)
VARIABLES = (*TRAINING_CANDIDATE, "DNNL_MAX_CPU_ISA", "ONEDNN_MAX_CPU_ISA", "OPENBLAS_L2_SIZE",
             "OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def _cpuinfo(field: str) -> str | None:
    """The first value of ``field`` in /proc/cpuinfo (Linux); None where there is none."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith(field):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return None


def cpu_model() -> str:
    """The CPU's model name (Linux: /proc/cpuinfo), else the platform's processor string."""
    return _cpuinfo("model name") or platform.processor() or platform.machine()


def cpu_flags() -> set[str]:
    """The CPU's feature flags (Linux: /proc/cpuinfo); empty where they cannot be read."""
    return set((_cpuinfo("flags") or "").split())


def can_pin() -> str | None:
    """None where ``PINNED`` can run here, else why not (it needs an x86-64 CPU with AVX2 and
    FMA)."""
    if platform.machine() not in ("x86_64", "AMD64"):
        return f"the pinned numerics are x86-64 kernels; this machine is {platform.machine()}"
    flags = cpu_flags()
    if flags and not {"avx2", "fma"} <= flags:
        return "the pinned numerics need a CPU with AVX2 and FMA"
    return None


def pinned_environ(environ: Mapping[str, str] | None = None) -> dict[str, str]:
    """``environ`` (default: this process's) with ``PINNED`` set over it."""
    return {**(os.environ if environ is None else environ), **PINNED}


def pin_numerics() -> None:
    """Set ``PINNED`` in this process's environment. It takes effect only for libraries not yet
    loaded: ``RuntimeError`` if NumPy was imported before (it has read its setting already)."""
    import sys

    if "numpy" in sys.modules and not pinned_here():
        raise RuntimeError("NumPy was imported before the numerics could be pinned: set "
                           + " ".join(f"{k}={v!r}" for k, v in PINNED.items())
                           + " in the environment before Python starts")
    os.environ.update(PINNED)


def pinned_here() -> bool:
    """Whether this process runs under ``PINNED``: the variables are set and NumPy, if
    imported, runs none of its AVX-512 code."""
    if any(os.environ.get(k) != v for k, v in PINNED.items()):
        return False
    import sys

    if "numpy" in sys.modules:
        features, _ = _numpy_simd()
        return not any(features.get(name) for name in NUMPY_AVX512)
    return True


def _numpy_simd() -> tuple[dict[str, bool], list[str]]:
    """NumPy's CPU features as it runs them (disabled ones False) and its dispatch targets."""
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # NumPy 1.x
        from numpy.core import _multiarray_umath as umath  # type: ignore[no-redef]
    return umath.__cpu_features__, list(umath.__cpu_dispatch__)


def describe() -> dict[str, Any]:
    """What numerics this process runs: the CPU, the variables of ``VARIABLES`` that are set,
    whether they are ``PINNED``, and NumPy's and torch's kernel levels where loaded."""
    import sys

    out: dict[str, Any] = {
        "cpu": cpu_model(),
        "avx512": "avx512f" in cpu_flags(),
        "pinned": pinned_here(),
        "environment": {k: os.environ[k] for k in VARIABLES if k in os.environ},
    }
    if "numpy" in sys.modules:
        features, dispatch = _numpy_simd()
        out["numpy_simd"] = [name for name in dispatch if features.get(name)]
    if "torch" in sys.modules:
        import torch

        out["torch_cpu_capability"] = torch.backends.cpu.get_cpu_capability()
    return out
