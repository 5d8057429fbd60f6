"""The structure that holds a SIMPLE batch's arrays for the compiled steps
(``rallysim.core.kernels.simple``): one Numba structref read by ``SimpleArrays``' names.

Its types live at module level, and this module is imported only when the kernels are
compiled (it imports Numba): Numba's cache finds a kernel by its argument types, which must be
the same objects in every process, as a class made inside a function is not.
"""

from __future__ import annotations

from typing import Any

from numba.core import types
from numba.experimental import structref

from rallysim.core import native
from rallysim.core.kernels.simple_arrays import SimpleArrays


@structref.register
class StateType(types.StructRef):
    def preprocess_fields(self, fields: Any) -> tuple:
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class State(structref.StructRefProxy):
    """``SimpleArrays`` in one object: a call then passes one object where it would pass each
    array (which costs the call time per array)."""


structref.define_proxy(State, StateType, list(SimpleArrays._fields))


def _new(arrays: tuple) -> State:
    return State(*arrays)


# compiled once per machine, as the kernels (a proxy's own constructor compiles per process)
_new_compiled = native.jit(_new)


def make(arrays: SimpleArrays) -> State:
    return _new_compiled(tuple(arrays))
