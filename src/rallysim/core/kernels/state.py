"""The structures that hold a batch's arrays for the compiled steps
(``rallysim.core.kernels.step``): one Numba structref per player kind, read by the names of its
arrays' named tuple (``rallysim.core.kernels.arrays``).

Their types live at module level, and this module is imported only when the kernels are
compiled (it imports Numba): Numba's cache finds a kernel by its argument types, which must be
the same objects in every process, as a class made inside a function is not.
"""

from __future__ import annotations

from typing import Any

from numba.core import types
from numba.experimental import structref

from rallysim.core import native
from rallysim.core.kernels.arrays import HumanLikeArrays, SimpleArrays


@structref.register
class SimpleStateType(types.StructRef):
    def preprocess_fields(self, fields: Any) -> tuple:
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


@structref.register
class HumanLikeStateType(types.StructRef):
    def preprocess_fields(self, fields: Any) -> tuple:
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class SimpleState(structref.StructRefProxy):
    """``SimpleArrays`` in one object: a call then passes one object where it would pass each
    array (which costs the call time per array)."""


class HumanLikeState(structref.StructRefProxy):
    """``HumanLikeArrays`` in one object."""


structref.define_proxy(SimpleState, SimpleStateType, list(SimpleArrays._fields))
structref.define_proxy(HumanLikeState, HumanLikeStateType, list(HumanLikeArrays._fields))


def _new_simple(arrays: tuple) -> SimpleState:
    return SimpleState(*arrays)


def _new_humanlike(arrays: tuple) -> HumanLikeState:
    return HumanLikeState(*arrays)


# compiled once per machine, as the kernels (a proxy's own constructor compiles per process)
_simple = native.jit(_new_simple)
_humanlike = native.jit(_new_humanlike)


def simple(arrays: SimpleArrays) -> SimpleState:
    return _simple(tuple(arrays))


def humanlike(arrays: HumanLikeArrays) -> HumanLikeState:
    return _humanlike(tuple(arrays))
