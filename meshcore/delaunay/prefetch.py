"""``prefetch``: a numba intrinsic asking the processor to load an array element ahead.

The Delaunay kernels' and the recovery's sequential loops are cache misses on
large inputs (the simplices' rows, hash tables); asking for the memory they
will read next overlaps those loads with the predicates. A hint only: the
values computed do not depend on it.
"""

from __future__ import annotations

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic


@intrinsic
def prefetch(typingctx, arr, idx):
    """Ask the processor to bring ``arr[idx]`` (the row ``idx`` of a 2D array)
    into its caches: LLVM's ``prefetch`` instruction, which never faults and
    changes no value, only when the later load finds the memory."""
    sig = types.void(arr, idx)

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        zero = context.get_constant(types.intp, 0)
        index = [context.cast(builder, args[1], signature.args[1], types.intp)]
        ptr = cgutils.get_item_pointer(
            context, builder, aryty, ary, index + [zero] * (aryty.ndim - 1), wraparound=False
        )
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32])
        # Named by llvmlite from the pointer type: llvm.prefetch.p0i8 with
        # LLVM's typed pointers (numba 0.59/0.60), llvm.prefetch.p0 after.
        fn = builder.module.declare_intrinsic("llvm.prefetch", [i8p], fnty)
        # read, keep in every cache level, data cache
        builder.call(fn, [builder.bitcast(ptr, i8p), i32(0), i32(3), i32(1)])
        return context.get_dummy_value()

    return sig, codegen
