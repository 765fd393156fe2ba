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
(the slots its machine code names) beside the caller's machine code.
"""
import ctypes
import hashlib
import importlib
import re
import weakref

from llvmlite import binding as ll
from llvmlite import ir
from numba.core import cgutils
from numba.core.caching import CompileResultCacheImpl, FunctionCache
from numba.core.imputils import fix_returning_optional, impl_ret_new_ref

_SLOTS = {}      # symbol -> ctypes.c_void_p holding the callee's address (kept alive here)
_CALLEES = {}    # symbol -> (module, qualname, argument types): the kernel it holds
_LOADED = weakref.WeakKeyDictionary()   # a library loaded from the cache -> what it calls
_SYMBOL = re.compile(rb"spacephys\.by_address\.[0-9a-f]{32}")


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
    _CALLEES[name] = (disp.py_func.__module__, disp.py_func.__qualname__, args)
    ctx = disp.targetctx
    ctx.remove_user_function(cres.entry_point)
    impl = _call_through(name, cres.fndesc)
    ctx.insert_func_defn([(impl, cres.entry_point, impl.signature)])


def _call_through(name, fndesc):
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
        return impl_ret_new_ref(context, builder, fndesc.restype, retval)

    imp.signature = fndesc.argtypes
    imp.libs = ()
    return imp


def needs(library):
    """{(module, qualname, argument types)}: the kernels that library's machine code calls by
    address, its own calls and those of the code numba linked into it (the slots its object
    code names)."""
    if library in _LOADED:
        return _LOADED[library]
    return _named_in(library.serialize_using_object_code())


def _named_in(libdata):
    """The kernels whose slots the serialised library libdata's object code names."""
    _, _, (code, _) = libdata
    return {_CALLEES[name.decode()] for name in set(_SYMBOL.findall(code))}


def load(need):
    """Compile or load the kernel a cached caller calls by address (which fills its slot)."""
    module, qualname, args = need
    disp = importlib.import_module(module)
    for part in qualname.split("."):
        disp = getattr(disp, part)
    disp.compile(args)


class _CacheImpl(CompileResultCacheImpl):
    def reduce(self, cres):
        # the library as numba serialised it (serialising again would write its bitcode twice)
        payload = super().reduce(cres)
        return payload, tuple(sorted(_named_in(payload[0]), key=str))

    def rebuild(self, target_context, payload):
        payload, wanted = payload
        for need in wanted:
            load(need)
        cres = super().rebuild(target_context, payload)
        _LOADED[cres.library] = set(wanted)
        return cres


class Cache(FunctionCache):
    """numba's cache of compiled kernels, which also keeps the kernels each one calls by
    address, and loads those first."""
    _impl_class = _CacheImpl
