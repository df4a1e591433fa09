"""Arrays the kernel reads without reference counts. Numba.

Every array value Numba binds to a variable or passes into a function is counted: an atomic
increment of its owner's count on the way in, a decrement on the way out (NRT_incref,
NRT_decref). The step passes ``StepData`` (some forty arrays), the work arrays and the law's
state into its parts, so a step of the ten-mode pendulum made about two thousand of them:
perf put 44 % of its time in the two functions (13 of 30 µs; measured 2026-12-04). The
arrays of a stretch are owned by its Python caller for the whole call, so the counting is
idle: :func:`unowned` gives the same arrays with a null owner, which Numba's count functions
pass over after one comparison.
"""
from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


def _without_owner(context, builder, typ, value):
    """``value`` of Numba type ``typ`` with every array's meminfo set to null (tuples and named
    tuples entry by entry; other values as they are)."""
    if isinstance(typ, types.Array):
        array = context.make_array(typ)(context, builder, value)
        array.meminfo = cgutils.get_null_value(array.meminfo.type)
        return array._getvalue()
    if isinstance(typ, types.BaseTuple):
        for i, item in enumerate(typ):
            entry = _without_owner(context, builder, item, builder.extract_value(value, i))
            value = builder.insert_value(value, entry, i)
    return value


@intrinsic
def unowned(typingctx, value):
    """``value`` (an array or a tuple of them, nested or named) referring to the same memory
    with no owner: nothing counts references to it, so it must not outlive the arrays it came
    from — :func:`step.run_stretch` makes it of its arguments, which its caller holds, and
    nothing it returns refers to them."""
    def codegen(context, builder, signature, args):
        return _without_owner(context, builder, signature.args[0], args[0])

    return value(value), codegen
