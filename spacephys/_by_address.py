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

A kernel that declares its return type (`kernel(returns=...)`) can be typed without being
compiled: while a kernel is compiled (inside `deferring()`: _jit.side_by_side, around a
scene's step and any compile a call from Python starts), a call to it is typed from the
declaration and compiled as a call through its slot, and the kernel is put on a list. Up to
`helpers` other Python processes (numba compiles on one core per process) take kernels
from the list as soon as they are put there, while this process goes on compiling the
caller; each compiles its kernel into the cache, reports each kernel it puts on its own
list as it meets it (it goes on this process's), and takes the next. `complete(helpers)`
compiles here what no helper took (one is kept for this process when it would otherwise
wait), waits for the helpers, and loads every kernel (filling its slot) before anything
runs. numba compiles a callee when the caller's typing reaches the call, one after
another; typed from declarations, the parts of a step are compiled on every core (arena's
cold first step 44.6 s with none, 30.5 s with the parts handed out once the step kernel
was compiled, 17-18 s handed out as soon as they are typed). The machine code is the same
either way. A call through a slot still empty raises a RuntimeError (its kernel's compile
failed, or has not ended); a helper that fails leaves its kernel to this process, and a
declaration that is not what the kernel returns is an error (TypeError).
"""
import atexit
import contextlib
import ctypes
import hashlib
import importlib
import pickle
import re
import subprocess
import sys
import threading
import time
import types as pytypes
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
_TYPED = set()   # (dispatcher, argument types) whose calls are lowered through the slot
_LOCAL = threading.local()     # .deferring: this thread is in deferring()
WAIT = 1800.0    # seconds: the longest a helper may take before its kernel is compiled here
_EMPTY = ("a kernel called by address is not compiled: its compile failed or has not ended "
          "(the next compile completes it)")

# a helper: compile each kernel it is sent into the cache, reporting the kernels it defers
# as it goes and None when one is done
_HELPER = """
import os, pickle, sys
sys.path[:0] = pickle.load(sys.stdin.buffer)
reports = os.fdopen(os.dup(1), "wb")      # nothing else, Python's or C's, written to them
os.dup2(2, 1)
from spacephys import _by_address
_by_address.serve(sys.stdin.buffer, reports)
"""


class _Work:
    """The kernels typed and not yet compiled, and the helpers compiling some of them:
    shared by the compiling thread and a thread per helper reading its reports. A job is
    (module, qualname, argument types, declared return type)."""

    def __init__(self):
        self.later = []       # jobs no one has taken
        self.seen = set()     # (module, qualname, argument types) of every job listed
        self.running = {}     # helper process -> (its job, time.monotonic() at its start)
        self.served = set()   # helper processes that finished a job
        self.idle = []        # helper processes waiting for a job
        self.ended = []       # jobs of helpers that ended, not yet collected by complete()
        self.helpers = 0      # how many helpers may run now
        self.broken = False   # a helper ended before it finished any job: start no
                              # more until this compile completes
        self.waiting = False  # complete() is here, about to take a job or waiting for one
        self.report = None    # in a helper: the stream each job it lists is written to
        self.changed = threading.Condition()


_WORK = _Work()


def symbol(py_func, args):
    """The slot's name for py_func compiled for the numba types args (the same in every
    process: it is how a cached caller finds it)."""
    key = f"{py_func.__module__}.{py_func.__qualname__}{tuple(str(a) for a in args)}"
    return "spacephys.by_address." + hashlib.sha256(key.encode()).hexdigest()[:32]


@contextlib.contextmanager
def deferring(helpers=0):
    """Within it, this thread's compiles type calls to kernels that declare their return type
    without compiling them, up to `helpers` other processes compiling those meanwhile (see
    the module); complete() must follow before anything runs."""
    was = getattr(_LOCAL, "deferring", False), _WORK.helpers
    _LOCAL.deferring, _WORK.helpers = True, helpers
    try:
        yield
    finally:
        _LOCAL.deferring, _WORK.helpers = was


def defers():
    """Whether this thread is in deferring()."""
    return getattr(_LOCAL, "deferring", False)


def defer(disp, args, restype):
    """A call to disp for args typed from its declared return type: its slot made (empty
    until the kernel is compiled or loaded), calls lowered through it, disp put on the list."""
    name = symbol(disp.py_func, args)
    if name not in _SLOTS:
        slot = _SLOTS[name] = ctypes.c_void_p(0)
        ll.add_symbol(name, ctypes.addressof(slot))
    _CALLEES[name] = (disp.py_func.__module__, disp.py_func.__qualname__, args)
    key = (disp, args)
    if key in _TYPED:
        return
    _TYPED.add(key)
    impl = _call_through(name, pytypes.SimpleNamespace(restype=restype, argtypes=args))
    disp.targetctx.insert_func_defn([(impl, key, args)])
    _list((disp.py_func.__module__, disp.py_func.__qualname__, args, restype))


def _list(job):
    """job on the list, once in this process (a helper: and reported), and handed out."""
    with _WORK.changed:
        if job[:3] in _WORK.seen:
            return
        _WORK.seen.add(job[:3])
        _WORK.later.append(job)
        if _WORK.report is not None:
            pickle.dump(job, _WORK.report)
            _WORK.report.flush()
        _hand_out()
        _WORK.changed.notify_all()


def pending():
    """Whether kernels were typed and not yet compiled (complete() compiles them)."""
    return bool(_WORK.later or _WORK.running or _WORK.ended)


def typed_key(disp, args):
    """The key a call to disp for args is lowered by while disp is typed but not compiled,
    or None."""
    key = (disp, args)
    return key if key in _TYPED and args not in disp.overloads else None


def complete(helpers=0):
    """Compile the kernels deferred so far (see the module), up to `helpers` of them at a
    time in other processes, then load each, so that every slot is filled. When it fails,
    every kernel it took goes back on the list (a helper still running is waited for by the
    next call): no slot is left empty behind a caller that may run, and the next call
    completes them."""
    done = []
    try:
        with deferring(helpers):
            _compile_all(done)
        _load(done)
    except BaseException:
        with _WORK.changed:
            _WORK.later[:0] = done
        raise
    finally:
        with _WORK.changed:
            _WORK.waiting = False
            _hand_out()                  # the idle helpers ended (none are allowed out here)
            _WORK.broken = False         # the next compile may try helpers again


def _load(done):
    """Every kernel of `done` loaded (compiled if a helper failed), its slot filled."""
    for module, qualname, args, restype in reversed(done):
        disp = kernel_named(module, qualname)
        disp.compile_for_kernels(args)
        got = disp.overloads[args].signature.return_type
        if got != restype:
            _SLOTS[symbol(disp.py_func, args)].value = 0     # no caller runs it mistyped
            raise TypeError(f"{module}.{qualname} returns {got} for {args}, but declares "
                            f"{restype}")


def _compile_all(done):
    """complete()'s compiling: the jobs no helper takes compiled here, and the helpers waited
    for; every job taken from the list put in `done`."""
    work = _WORK
    while True:
        with work.changed:
            work.waiting = True
            _hand_out()
            done.extend(work.ended)
            work.ended.clear()
            if not work.later:
                if not work.running:
                    return
                work.changed.wait(1.0)
                for process, (_, started) in work.running.items():
                    if time.monotonic() - started > WAIT:
                        process.kill()               # its reader then ends it
                continue
            job = work.later.pop(0)
            done.append(job)
            work.waiting = False
        kernel_named(job[0], job[1]).compile_for_kernels(job[2])


def _hand_out():
    """Give the oldest jobs of the list to helpers, idle ones first, new ones while fewer
    than _WORK.helpers run, keeping one for this process when complete() would otherwise
    wait; end the idle helpers beyond _WORK.helpers. Called holding the lock."""
    work = _WORK
    while len(work.later) > (1 if work.waiting else 0) and len(work.running) < work.helpers:
        try:
            payload = pickle.dumps(pickle.dumps(work.later[0]))
        except Exception:                # a type that does not pickle: this process takes it
            break
        if work.idle:
            process = work.idle.pop(0)
            if not _send(process, payload):
                process.kill()
                continue
        elif len(work.running) + len(work.idle) < work.helpers and not work.broken:
            process = _start_helper(payload)
            if process is None:
                work.broken = True
                break
        else:
            break
        work.running[process] = (work.later.pop(0), time.monotonic())
    while work.idle and len(work.running) + len(work.idle) > work.helpers:
        work.idle.pop().stdin.close()                # it ends


def _start_helper(payload):
    """A helper process given its first job (a pickled job), its reader started; None when
    it cannot be started."""
    process = None
    try:
        process = subprocess.Popen([sys.executable, "-c", _HELPER], stdin=subprocess.PIPE,
                                   stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        process.stdin.write(pickle.dumps([p for p in sys.path if isinstance(p, str)]))
        if _send(process, payload):
            threading.Thread(target=_read, args=(process,), daemon=True).start()
            return process
    except Exception:                    # no interpreter to start, no thread
        pass
    if process is not None:
        process.kill()
        process.wait()
    return None


def _send(process, payload):
    """Send a pickled job to a helper; False when it cannot take it (it ended)."""
    try:
        process.stdin.write(payload)
        process.stdin.flush()
        return True
    except Exception:
        return False


def _read(process):
    """A helper's reader: each job it reports listed here, and its job done when it says so
    or ends (what it compiled is in the cache)."""
    try:
        while True:
            report = pickle.load(process.stdout)
            if report is None:
                _done(process, idle=True)
            else:
                _list(report)
    except EOFError:                     # the end of its reports: it ends
        pass
    except Exception:                    # a broken report: it may still wait for a job
        process.kill()
    process.stdout.close()
    process.wait()
    _done(process, idle=False)


def _done(process, idle):
    """process finished its job and waits for another (idle), or ended: a job it did not
    finish goes back on the list, and a helper that ended before finishing any stops more
    from being started (a Python that cannot import spacephys, say)."""
    with _WORK.changed:
        job = _WORK.running.pop(process, None)
        if idle:
            _WORK.served.add(process)
            _WORK.idle.append(process)
            if job is not None:
                _WORK.ended.append(job[0])
        else:
            if job is not None:
                _WORK.later.insert(0, job[0])
            if process not in _WORK.served:
                _WORK.broken = True
            _WORK.served.discard(process)
            if process in _WORK.idle:
                _WORK.idle.remove(process)
        _hand_out()
        _WORK.changed.notify_all()


def _end_helpers():
    """At exit: every helper ended (a running one would otherwise finish its kernel)."""
    with _WORK.changed:
        for process in list(_WORK.running) + _WORK.idle:
            process.kill()


atexit.register(_end_helpers)


def serve(stdin, stdout):
    """A helper process's work (_HELPER): compile each job read from stdin into the cache,
    writing each job it defers to stdout as it is deferred, and None after each job."""
    _WORK.report = stdout
    while True:
        try:
            module, qualname, args, _ = pickle.loads(pickle.load(stdin))
        except EOFError:
            return
        with deferring():
            kernel_named(module, qualname).compile_for_kernels(args)
        pickle.dump(None, stdout)
        stdout.flush()


def kernel_named(module, qualname):
    """The kernel `qualname` of `module`."""
    disp = importlib.import_module(module)
    for part in qualname.split("."):
        disp = getattr(disp, part)
    return disp


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
        address = builder.load(slot)
        # an empty slot (its kernel's compile failed, or has not ended) raises, never jumps
        with cgutils.if_unlikely(builder, cgutils.is_null(builder, address)):
            context.call_conv.return_user_exc(builder, RuntimeError, (_EMPTY,))
        callee = builder.bitcast(address, fnty.as_pointer())
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
    kernel_named(module, qualname).compile_for_kernels(args)


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
