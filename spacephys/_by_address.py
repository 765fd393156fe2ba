"""Kernels called by address: compiled once on their own, and called from other kernels
through a pointer instead of being compiled into them.

numba compiles a call from one kernel to another by linking the callee's code into the
caller's module and optimising and translating the whole again: a large callee costs its
compile time once more in every kernel that calls it, and in every kernel that calls those
(the step kernel's collision pass: 3.5 of its 3.8 s). A kernel made with
`kernel(by_address=True)` is instead reached through a slot: a pointer-sized global named
after the callee and its argument types, which holds the address of its machine code. The
caller loads the slot and calls through it (numba's own calling convention, so exceptions
and return values pass as in a direct call); nothing of the callee is in its module. The
price is the call itself, a few nanoseconds, and that LLVM cannot inline it: for a callee
that runs once a step and takes microseconds.

The slot is a symbol of the process (llvmlite's add_symbol), filled when the callee is
compiled or loaded from the cache. A cached caller refers to it by name, so before numba
loads a caller from the cache the callees it needs are loaded first: `Cache` stores the list
beside the caller's machine code.
"""
import ctypes
import hashlib
import importlib

from llvmlite import binding as ll
from llvmlite import ir
from numba.core import cgutils
from numba.core.caching import CompileResultCacheImpl, FunctionCache
from numba.core.imputils import fix_returning_optional, impl_ret_new_ref

_SLOTS = {}      # symbol -> ctypes.c_void_p holding the callee's address (kept alive here)


def symbol(py_func, args):
    """The slot's name for py_func compiled for the numba types args (the same in every
    process: it is how a cached caller finds it)."""
    key = f"{py_func.__module__}.{py_func.__qualname__}{tuple(str(a) for a in args)}"
    return "spacephys.by_address." + hashlib.sha256(key.encode()).hexdigest()[:32]


def publish(disp, cres):
    """After disp compiled or loaded cres: its address in the slot, and calls from other
    kernels compiled as calls through the slot (replacing numba's direct call)."""
    args = tuple(cres.signature.args)
    name = symbol(disp.py_func, args)
    address = cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)
    slot = _SLOTS.get(name)
    if slot is None:
        slot = _SLOTS[name] = ctypes.c_void_p(address)
        ll.add_symbol(name, ctypes.addressof(slot))
    else:
        slot.value = address
    ctx = disp.targetctx
    ctx.remove_user_function(cres.entry_point)
    impl = _call_through(name, cres.fndesc, (disp.py_func.__module__,
                                              disp.py_func.__qualname__, args))
    ctx._defns[cres.entry_point].append(impl, impl.signature)


def _call_through(name, fndesc, need):
    def imp(context, builder, sig, args):
        module = builder.module
        slot = module.globals.get(name)
        if slot is None:
            slot = ir.GlobalVariable(module, cgutils.voidptr_t, name)   # a declaration
        fnty = context.call_conv.get_function_type(fndesc.restype, fndesc.argtypes)
        callee = builder.bitcast(builder.load(slot), fnty.as_pointer())
        status, retval = context.call_conv.call_function(
            builder, callee, fndesc.restype, fndesc.argtypes, args)
        with cgutils.if_unlikely(builder, status.is_error):
            context.call_conv.return_status_propagate(builder, status)
        retval = fix_returning_optional(context, builder, sig, status, retval)
        _needs_of(context.active_code_library).add(need)
        return impl_ret_new_ref(context, builder, fndesc.restype, retval)

    imp.signature = fndesc.argtypes
    imp.libs = ()
    return imp


def _needs_of(library):
    """{(module, qualname, argument types)}: the kernels library's own code calls by
    address (kept on the library)."""
    if not hasattr(library, "_by_address"):
        library._by_address = set()
    return library._by_address


def needs(library):
    """The kernels called by address from library's code or the code linked into it."""
    out, seen, todo = set(), set(), [library]
    while todo:
        lib = todo.pop()
        if id(lib) in seen:
            continue
        seen.add(id(lib))
        out |= getattr(lib, "_by_address", set())
        todo.extend(getattr(lib, "_linking_libraries", ()))
    return out


def load(need):
    """Compile or load the kernel a cached caller calls by address (which fills its slot)."""
    module, qualname, args = need
    disp = importlib.import_module(module)
    for part in qualname.split("."):
        disp = getattr(disp, part)
    disp.compile(args)


class _CacheImpl(CompileResultCacheImpl):
    def reduce(self, cres):
        return super().reduce(cres), tuple(sorted(needs(cres.library), key=str))

    def rebuild(self, target_context, payload):
        payload, wanted = payload
        for need in wanted:
            load(need)
        cres = super().rebuild(target_context, payload)
        _needs_of(cres.library).update(wanted)
        return cres


class Cache(FunctionCache):
    """numba's cache of compiled kernels, which also keeps the kernels each one calls by
    address, and loads those first."""
    _impl_class = _CacheImpl
