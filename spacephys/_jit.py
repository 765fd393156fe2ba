"""The one decorator every numba kernel uses: caching, floating-point and parallel policy in
one place.

No kernel is compiled with a fastmath flag: reassociation would let LLVM split a sum into as
many partial sums as the CPU's vectors hold, contraction would fuse multiply-adds where the
CPU has them, and either makes results differ between x86-64 CPUs. Without them every
operation rounds as written (IEEE 754, as the source orders it), so a result depends on
the inputs and the numba/LLVM version only; the force sums are laid out to vectorise
without reordering (kernels/pairs.py), and a kernel that fuses a multiply-add says so (fma)."""
import contextlib
import gc
import os
import sys
import threading
import time
import warnings

# numba's OpenMP threads (GNU libgomp) spin on a core after each threaded loop before they
# sleep: 300 000 spins by default, long enough that beside a busy process (a game's own
# threads, another program) the spinning thread and the process share a core and the step's
# serial part loses time (the fleet battle with a core busy: 95th percentile 14.1 ms, 8.6
# with 10 000 spins; quiet and threaded figures unchanged; no spinning at all,
# OMP_WAIT_POLICY=passive, made 256 bodies 3.7x slower). libgomp reads it when numba first
# loads it, at the first threaded loop; a value the user set is kept.
os.environ.setdefault("GOMP_SPINCOUNT", "10000")

import numba  # noqa: E402
import numpy as np  # noqa: E402

from . import cache as _cache  # noqa: E402  (the cache folder, before any kernel is defined)
from . import _by_address  # noqa: E402
from numba import types
from numba.core import cgutils, compiler, sigutils, typed_passes, typing, utils
from numba.core.compiler_lock import global_compiler_lock
from numba.core.compiler_machinery import register_pass
from numba.core.errors import NumbaPerformanceWarning, RequireLiteralValue
from numba.core.registry import CPUDispatcher
from numba.experimental.structref import _Utils
from numba.extending import intrinsic, overload
from llvmlite import ir

# With prange-only parallelism (PRANGE_ONLY) numba's check for "a parallel transformation"
# misses the prange loops of inlined helpers and warns on kernels that do run threaded (the
# Gauss-Radau kernel: measured 1.5 ms per step on 2 threads, 2.4 ms on 1, N = 512)
warnings.filterwarnings("ignore", message=r"\s*The keyword argument 'parallel=True' was "
                        "specified but no transformation", category=NumbaPerformanceWarning)


# Below this many pair evaluations a serial loop beats starting the thread pool on an idle
# machine (measured: crossover between 64 and 128 bodies, i.e. 4e3..1.6e4 pairs, on a 2-core
# AMD EPYC). Whether a loop above it runs on threads is ThreadChoice's call.
PARALLEL_MIN_PAIRS = 10_000
NEVER = np.iinfo(np.int64).max
THREAD_MODES = ("auto", "always", "never")
PROBE_MAX = 0.01           # seconds: the longest call ThreadChoice tries the other choice on
TRIAL_CALLS = 3            # calls one trial of the other choice lasts


class TableType(types.StructRef):
    """The numba type of the kernels' tables (structrefs: State, Forces, Rules, Actors): its
    fields typed by value, not as literals (dim = 2 is an int64, not Literal[int](2)), so
    one compiled kernel serves every table of a kind."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(t)) for name, t in fields)


PRANGE_ONLY = {"prange": True, "comprehension": False, "reduction": False,
               "inplace_binop": False, "setitem": False, "numpy": False, "stencil": False,
               "fusion": False}


def kernel(fn=None, *, parallel=False, inline=False, lean=False, counted=False,
           by_address=False, forceinline=False, returns=None):
    """Compile `fn` with numba: cached, numpy error model (x/0 gives inf, no exception check).

    parallel : compile prange loops to threads.
    inline : inline into callers at numba-IR level (per call site: it costs compile time, it
    saves the call; used for the small per-step and per-force helpers). lean : compiled
    without reference counting (numba's _nrt=False): for the helpers a step loop calls many
    times with arrays it read once (see forces.hoist), where every array passed to a helper
    would otherwise cost two atomic operations per call (measured 10 ns the pair here, 43% of
    a small prediction's time); such a helper takes arrays and numbers only, and allocates
    nothing. A function compiled for a lean caller is itself lean unless it says otherwise
    (numba's callees inherit the caller's reference counting): counted : compiled with
    reference counting whoever calls it, for the functions a lean one may call that allocate
    or hold numba's typed lists (the tree, user forces). A function that holds
    a prange, or calls one that does, is itself parallel: a cached serial kernel that calls a
    parallel one segfaults when loaded from the cache (numba issue #8578).
    by_address : compiled once on its own and called from other kernels through a pointer
    (spacephys/_by_address.py), so that no caller compiles it again: for a large kernel that
    runs once a step.
    returns : for a by_address kernel, its return type (a numba type), so that a call to it
    can be typed before it is compiled and the parts of a step compiled side by side
    (_by_address.complete).
    forceinline : inlined by LLVM into every caller (numba's forceinline), for the functions
    a step calls each step or force evaluation with the hoisted tables: numba hands each
    array on as 7-9 machine words, so a call that takes a table's arrays pushes about 140
    words, and LLVM's inliner left such calls in place. 2 bodies with leapfrog: 190 ns a
    step before, 67 after (95 of the 118 ns without gravity were these calls). Not
    inherited: a function it calls is inlined only if it says so too.
    """
    opts = _options(parallel, inline, lean, counted, forceinline)
    cls = _ByAddress if by_address else _Dispatcher

    def made(f):
        disp = _compiled(f, opts, cls)
        disp.returns = returns
        return disp
    return made if fn is None else made(fn)


class _Dispatcher(CPUDispatcher):
    """numba's dispatcher, but a call from another kernel compiles it for its arguments'
    plain types: numba would compile a function again for every constant an argument is
    given (walk(..., False) and walk(..., same) twice; a prange index, uint64, once more),
    and each copy re-optimises everything it calls. Branches on None stay pruned (None is a
    type of its own)."""

    def get_call_template(self, args, kws):
        with _bare():
            return super().get_call_template(tuple(types.unliteral(a) for a in args),
                                             {k: types.unliteral(v) for k, v in kws.items()})

    # numba builds every compiled function a wrapper that Python calls it through: 20-30 ms of
    # LLVM work apiece, for most kernels never called from Python. A kernel is compiled
    # without one for the kernels that call it (get_call_template, _bare: _Pipeline's
    # lowering leaves it out); numba's dispatch from Python misses such a kernel (it is not
    # in the table, add_overload), which is then compiled (or loaded) again with one. Not
    # decided in compile(): any override of it, even one that only called numba's, made the
    # tree scenes' cold start 25 % slower (docs/history.md).
    def _compile_for_args(self, *args, **kws):
        with _bare(False), compiling(), global_compiler_lock:
            bare = [sig for sig, cres in self.overloads.items() if not _wrapped(cres)]
            if bare:
                called = None if kws else tuple(self.typeof_pyval(a) for a in args)
                for sig in [called] if called in bare else bare:
                    del self.overloads[sig]
            try:
                with side_by_side():
                    return super()._compile_for_args(*args, **kws)
            except BaseException:
                # numba put the kernel in its table as it compiled: taken out again, so that
                # a call from Python does not run it while a kernel it calls has no code
                # (the next call compiles, or loads, it again and completes the rest)
                self._reset_overloads()
                raise

    def compile_for_kernels(self, sig):
        """compile(sig) for other kernels to call, not Python."""
        with _bare(), compiling():
            return self.compile(sig)

    def add_overload(self, cres):
        if _wrapped(cres):
            super().add_overload(cres)
        else:                          # not callable from Python: not in numba's table
            self.overloads[tuple(cres.signature.args)] = cres

    def enable_caching(self):
        self.__dict__["_cache"] = None          # made by the first compile or load (below)

    @property
    def _cache(self):
        """numba's cache of this kernel, made when first used: making one checks that its
        folder is writable with a temporary file, which for every kernel at import took
        20 ms of a warm start."""
        cache = self.__dict__["_cache"]
        if cache is None:
            cache = self.__dict__["_cache"] = _Cache(self.py_func)
        return cache

    @_cache.setter
    def _cache(self, value):
        self.__dict__["_cache"] = value


# Python's cyclic collector while kernels compile: the first generation collected every 100 000
# allocations instead of 700, the older ones almost never. numba's compile makes about a
# million objects, and each collection of the older generations walks all of them: ring's
# cold first step 20.2 -> 18.4 s (alternated, three runs and two), its peak memory 288 -> 317
# MB (with the collector off, 18.1 s and 415 MB).
COMPILE_GC = (100_000, 1000, 1000)
_GC = {"depth": 0, "was": None}
_GC_LOCK = threading.Lock()


@contextlib.contextmanager
def compiling():
    """Within it (and any nested in it, on any thread), the collector's COMPILE_GC thresholds;
    the process's own are put back when the last one ends."""
    with _GC_LOCK:
        if _GC["depth"] == 0:
            _GC["was"] = gc.get_threshold()
            gc.set_threshold(*COMPILE_GC)
        _GC["depth"] += 1
    try:
        yield
    finally:
        with _GC_LOCK:
            _GC["depth"] -= 1
            if _GC["depth"] == 0:
                gc.set_threshold(*_GC["was"])


@contextlib.contextmanager
def side_by_side():
    """Within it, calls to kernels that declare what they return are typed from the
    declaration, and the kernels are compiled when it ends, in up to helpers() other
    processes as well as this one (spacephys/_by_address.py); under numba's lock. A call
    through a slot still empty raises (RuntimeError), it never jumps to nothing."""
    count = helpers()                    # a bad value refused before anything is compiled
    with global_compiler_lock:
        with _by_address.deferring(count):
            yield
        if _by_address.pending():        # (what a compile that failed left is done here too)
            _by_address.complete(count)


def helpers():
    """How many helper processes a compile may start: SPACEPHYS_COMPILE_HELPERS when set,
    else one fewer than the cores no other program is using (Linux's count of runnable
    threads; elsewhere, none)."""
    told = os.environ.get("SPACEPHYS_COMPILE_HELPERS")
    if told is not None:
        try:
            return max(0, int(told))
        except ValueError:
            raise ValueError(f"SPACEPHYS_COMPILE_HELPERS = {told!r}: expected a whole "
                             f"number of processes (0: none)") from None
    if not _cache.ENABLED or getattr(sys, "frozen", False):
        return 0                     # helpers hand their machine code over through the cache
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        return 0
    taken = _cores_taken()
    return 0 if taken is None else max(0, cores - 1 - taken)


class _Bare(threading.local):
    on = False


_BARE = _Bare()      # this thread compiles for a caller kernel, not for Python (_bare)


@contextlib.contextmanager
def _bare(on=True):
    """Within it, this thread's kernel compiles are for other kernels: without the wrapper
    Python calls through."""
    was, _BARE.on = _BARE.on, on
    try:
        yield
    finally:
        _BARE.on = was


def _lowering(base):
    """numba's lowering pass `base`, leaving out Python's wrapper while _BARE.on. Decided
    here, not by the compile flags a kernel is compiled with: numba keys its typing of the
    functions a kernel inlines by those flags, and two sets of them would type each twice."""
    class Lowering(base):
        _name = base.name()

        def run_pass(self, state):
            if not _BARE.on:
                return super().run_pass(state)
            flags = state.flags
            state.flags = flags.copy()
            state.flags.no_cpython_wrapper = True
            try:
                return super().run_pass(state)
            finally:
                state.flags = flags
    return register_pass(mutates_CFG=True, analysis_only=False)(Lowering)


class _Pipeline(compiler.Compiler):
    """numba's compiler, lowering with _lowering."""
    _LOWERING = {base: _lowering(base) for base in (typed_passes.NativeLowering,
                                                      typed_passes.NativeParforLowering)}

    def define_pipelines(self):
        pipelines = super().define_pipelines()
        for pm in pipelines:
            pm.passes = [(self._LOWERING.get(cls, cls), what) for cls, what in pm.passes]
            pm.finalize()
        return pipelines


def _wrapped(cres):
    """Whether Python can call the compiled cres (it has numba's wrapper)."""
    return cres.objectmode or bool(cres.library.get_pointer_to_function(
        cres.fndesc.llvm_cpython_wrapper_name))


class _Cache(_by_address.Cache):
    """The kernels' cache, which keeps a kernel compiled without Python's wrapper apart from
    one with it; a kernel's callers take either."""
    _bare_key = False

    def _index_key(self, sig, codegen):
        key = super()._index_key(sig, codegen)
        return key + ("bare",) if self._bare_key else key

    def _load_overload(self, sig, target_context):
        args = tuple(sigutils.normalize_signature(sig)[0])
        for bare in (True, False) if _BARE.on else (False,):
            with self._keyed(bare):
                cres = super()._load_overload(sig, target_context)
            # an entry whose file holds another entry's code (two processes that saved at
            # once without cache.saving's lock: an older cache) is compiled again, and saved
            # over it
            if cres is not None and tuple(cres.signature.args) == args and (
                    bare or _wrapped(cres)):
                return cres
        return None

    def _save_overload(self, sig, data):
        with self._keyed(not _wrapped(data)), _cache.saving():
            super()._save_overload(sig, data)

    @contextlib.contextmanager
    def _keyed(self, bare):
        """Within it, the index keys are those of code with (bare False) or without the
        wrapper (under numba's compile lock, as every load and save)."""
        self._bare_key = bare
        try:
            yield
        finally:
            self._bare_key = False


class _ByAddress(_Dispatcher):
    """A kernel other kernels call through its address (kernel's by_address), typed from
    its declared return type while deferring (spacephys/_by_address.py)."""
    returns = None

    def get_call_template(self, args, kws):
        args = tuple(types.unliteral(a) for a in args)
        if self.returns is None or kws or args in self.overloads or not _by_address.defers():
            return super().get_call_template(args, kws)
        _by_address.defer(self, args, self.returns)
        sig = typing.signature(self.returns, *args)
        template = typing.make_concrete_template(f"CallTemplate({self.py_func.__name__})",
                                                 key=self.py_func.__name__, signatures=[sig])
        return template, utils.pysignature(self.py_func), args, kws

    def get_overload(self, sig):
        key = _by_address.typed_key(self, tuple(sigutils.normalize_signature(sig)[0]))
        return key if key is not None else super().get_overload(sig)

    def add_overload(self, cres):
        super().add_overload(cres)
        _by_address.publish(self, cres)


def _compiled(fn, opts, cls):
    opts = dict(opts, nopython=True)
    cache = opts.pop("cache")
    disp = cls(py_func=fn, locals={}, targetoptions=opts, pipeline_class=_Pipeline)
    if cache and _cache.ENABLED:
        disp.enable_caching()
    return disp


def _options(parallel=False, inline=False, lean=False, counted=False, forceinline=False):
    # no_cfunc_wrapper: numba would build every function a wrapper callable from C (100 of
    # them, 2.1 s of a Gauss-Radau scene's profiled cold first step); no kernel is called so.
    # Only explicit prange loops become threaded: numba would also turn array expressions and
    # numpy calls (np.zeros, np.cumsum) into parallel regions, which wake the thread pool on
    # every call however small the scene, and stall for milliseconds when another process or
    # a game's own threads hold the cores
    if parallel:
        parallel = dict(PRANGE_ONLY)
    opts = dict(cache=True, nogil=True, error_model="numpy", parallel=parallel,
                fastmath=False, inline="always" if inline else "never",
                forceinline=forceinline, no_cfunc_wrapper=True)
    if lean or counted:
        opts["_nrt"] = not lean
    return opts


def implements(stub, fn, when, **options):
    """Make the plain function fn what kernels calling `stub` run when `when(the numba types
    of the arguments)` holds, compiled with `kernel`'s options: numba chooses as it compiles
    the caller, and calls fn itself (no function in between, whose compilation would
    re-optimise everything fn calls once more). Kernels that call `stub` are cached as any
    other; fn is compiled into them."""
    opts = _options(**options)
    inline = opts.pop("inline")
    del opts["cache"]

    @overload(stub, jit_options=opts, strict=False, inline=inline)
    def choose(*args):
        if when(*args):
            return fn
    return choose


def _borrowed_data(context, builder, utils, value):
    """The data struct of structref `value` in a kernel compiled without the runtime (lean):
    the meminfo's data pointer read as the runtime's own inline accessor reads it (the
    fourth field, NRT_MemInfo_data_fast), so that a lean kernel can take a table whole, a
    pointer through a call, and read it itself, borrowed from its caller."""
    meminfo = builder.bitcast(utils.get_struct_ref(value).meminfo,
                              _MEMINFO.as_pointer())
    data = builder.load(cgutils.gep(builder, meminfo, 0, 3))
    model = context.data_model_manager[utils.struct_type.get_data_type()]
    data = builder.bitcast(data, model.get_value_type().as_pointer())
    return cgutils.create_struct_proxy(utils.struct_type.get_data_type())(
        context, builder, ref=data)


# the runtime's MemInfo: refct, dtor, dtor_info, data, size (numba/core/runtime/nrtdynmod.py)
_MEMINFO = ir.LiteralStructType([ir.IntType(64), ir.IntType(8).as_pointer(),
                                 ir.IntType(8).as_pointer(), ir.IntType(8).as_pointer(),
                                 ir.IntType(64)])


@intrinsic
def read(typingctx, table, arrays):
    """arrays(table.f for f in arrays' fields): the fields of the structref `table` that the
    namedtuple class `arrays` names, read at once (a kernel's tables hoisted before its step
    loop: the fields listed once, in the namedtuple)."""
    cls = arrays.instance_class
    fields = table.field_dict
    tys = [fields[name] for name in cls._fields]
    out = types.NamedTuple(tys, cls)
    sig = out(table, arrays)

    def codegen(context, builder, sig, args):
        utils = _Utils(context, builder, sig.args[0])
        if context.enable_nrt:
            data = utils.get_data_struct(args[0])
        else:
            data = _borrowed_data(context, builder, utils, args[0])
        values = []
        for name, ty in zip(cls._fields, tys):
            value = getattr(data, name)
            if context.enable_nrt:
                context.nrt.incref(builder, ty, value)     # a new reference, as getattr's
            values.append(value)
        return context.make_tuple(builder, out, values)
    return sig, codegen


@intrinsic
def stack_rows(typingctx, like, rows, cols):
    """A (rows, cols) C-ordered array of like's type on the stack of the kernel that calls
    it (rows and cols constants): scratch for a kernel that allocates nothing (lean) or for
    each thread of a prange. Uninitialised; valid until that kernel returns, never to be
    returned or kept."""
    for n in (rows, cols):
        if not isinstance(n, types.IntegerLiteral):
            raise RequireLiteralValue(n)
    shape = (rows.literal_value, cols.literal_value)
    dtype = types.unliteral(like)
    aryty = types.Array(dtype, 2, "C")

    def codegen(context, builder, sig, args):
        item = context.get_value_type(dtype)
        size = context.get_abi_sizeof(item)
        intp = context.get_value_type(types.intp)
        # in the entry block of the function the call is compiled into
        data = cgutils.alloca_once(builder, item, size=shape[0] * shape[1])
        # numba's array struct, field by field (no meminfo, no parent: nothing to count)
        model = context.data_model_manager[aryty]
        value = cgutils.get_null_value(context.get_value_type(aryty))
        for name, field in (("nitems", intp(shape[0] * shape[1])), ("itemsize", intp(size)),
                            ("data", data),
                            ("shape", cgutils.pack_array(builder, [intp(n) for n in shape])),
                            ("strides", cgutils.pack_array(builder, [intp(shape[1] * size),
                                                                     intp(size)]))):
            value = builder.insert_value(value, field, model.get_field_position(name))
        return value
    return aryty(like, rows, cols), codegen


@intrinsic
def fma(typingctx, a, b, c):
    """a * b + c rounded once (IEEE 754's fusedMultiplyAdd), floats of one type: one FMA
    instruction where the CPU has them, else the C library's fma, which rounds the same
    (correctly) in software. The one way a kernel fuses a multiply-add: numba's `contract`
    flag would fuse only where the target has FMA, so the bits would depend on the CPU."""
    if not (isinstance(a, types.Float) and a == b == c):
        return None

    def codegen(context, builder, sig, args):
        t = args[0].type
        fn = builder.module.declare_intrinsic("llvm.fma", [t], ir.FunctionType(t, [t, t, t]))
        return builder.call(fn, args)
    return a(a, b, c), codegen


def field_type(t, name):
    """The numba type of field `name` of the namedtuple type t."""
    return t.types[t.fields.index(name)]


def is_table(t, table):
    """Whether the numba type t is that of the namedtuple class `table`."""
    return isinstance(t, types.BaseNamedTuple) and t.instance_class is table


_cache.purge_stale()


def set_threads(n):
    """Use up to n threads (1 .. the machine's cores) for the force loops of large scenes;
    returns the previous count. Results do not depend on it. Whether a World's loops use
    them at all is World.threads ("auto" by default: while they measure faster, see
    ThreadChoice). The count is per Python thread (numba's): call it in the thread that steps
    the World."""
    from . import _validate as check
    limit = numba.config.NUMBA_NUM_THREADS
    n = check.count("n", n, minimum=1)
    if n > limit:
        raise ValueError(f"n = {n}: at most {limit} threads (the machine's cores, or "
                         f"NUMBA_NUM_THREADS)")
    previous = numba.get_num_threads()
    numba.set_num_threads(n)
    return previous


def get_threads():
    """The number of threads the force loops of large scenes use (see set_threads)."""
    return numba.get_num_threads()


@contextlib.contextmanager
def announced(what, after=0.5):
    """Say on stderr when the block takes longer than `after` seconds: numba is compiling
    `what`, once, and where the result is cached; then how long it took. Quiet when the
    compiled code comes from the cache."""
    done = threading.Event()
    said = []
    start = time.perf_counter()

    def say():
        if not done.wait(after):
            print(f"spacephys: compiling {what} with numba; this happens once per machine and "
                  f"version (machine code cache: {_cache.place()})", file=sys.stderr,
                  flush=True)
            said.append(True)

    thread = threading.Thread(target=say, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()
        if said:
            print(f"spacephys: compiled in {time.perf_counter() - start:.1f} s", file=sys.stderr,
                  flush=True)


def _others_running():
    """Linux's count of running threads (/proc/loadavg) less this process's own in state R
    (its OpenMP threads spin a moment after a loop). OSError, IndexError or ValueError where
    there are no such files."""
    with open("/proc/loadavg", "rb") as f:
        running = int(f.read().split()[3].split(b"/")[0])
    own = 0
    for task in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{task}/stat", "rb") as f:
                own += f.read().rsplit(b")", 1)[1].split()[0] == b"R"
        except (OSError, IndexError):
            pass                                   # the thread ended meanwhile
    return running - max(1, own)


def _cores_taken():
    """How many runnable threads other programs have now (_others_running): when the first
    look sees any, the least of it and a second look 0.2 ms later, so that a thread that ran
    for an instant does not count (one look: 50 us). None where there are no such files."""
    try:
        seen = _others_running()
        if seen > 0:
            time.sleep(0.0002)
            seen = min(seen, _others_running())
    except (OSError, IndexError, ValueError):
        return None
    return max(0, seen)


def _crowded():
    """Whether other work holds cores this process's threads would need: a threaded loop
    then waits for its slowest, descheduled thread (beside one busy process on 2 cores,
    1 000 steps of star_system took 0.49-4.3 s on threads, 0.24 s on one)."""
    taken = _cores_taken()
    return taken is not None and (os.cpu_count() or 1) - taken < numba.config.NUMBA_NUM_THREADS


class ThreadChoice:
    """Whether one World's force loops run on threads, chosen by the work and by what the
    threads deliver. Results are the same bit for bit either way; only the time differs.

    mode "always": every loop of PARALLEL_MIN_PAIRS pair evaluations or more runs on threads
    (a machine whose cores are the simulation's); "never": none does; "auto" (default): only
    loops that large may, and only while threads measure faster. Beside busy processes (a
    game's render and audio threads) a threaded loop can wait for a descheduled thread
    (measured here: 8 ms per step where one thread took 0.03-0.5 ms, on some runs of this
    virtual machine). So each step() call is timed per step, the other choice is tried now
    and then (after 1 s, then twice as long each time it loses, up to a minute; at once when
    the current choice's last calls all cost 4x more: one descheduled call does not count)
    and the faster kept. A trial is TRIAL_CALLS
    calls and counts the fastest of them, compared with the fastest of the current choice's
    last TRIAL_CALLS: the first call after a switch pays for waking or parking the pool. A
    call too long to try the other choice on (a run, a warp; and the first calls) runs on
    threads only when no other work holds the cores they need (_crowded: Linux's count of
    runnable threads), and a trial of threads waits while it does; the first two calls of a
    scene, which load kernels and build tables, are not timed.
    """

    def __init__(self, mode="auto"):
        self.min_pairs = np.array([NEVER], np.int64)    # read by the kernels' force loops
        self.mode = "auto"
        self.set(mode)

    def set(self, mode):
        if mode not in THREAD_MODES:
            raise ValueError(f"threads={mode!r} is not known; valid: {', '.join(THREAD_MODES)}")
        self.mode = mode
        self.min_pairs[0] = PARALLEL_MIN_PAIRS if mode != "never" else NEVER
        self.threaded = True
        self.work = 1.0                                # pair evaluations they were measured at
        self._measure_afresh()
        self.settle = 0

    def _measure_afresh(self):
        self.cost = {True: np.inf, False: np.inf}      # seconds per step, measured
        self.recent = []                               # the current choice's last calls
        self.trial = 0                                 # calls of the trial still to make
        self.probe_at = 0.0
        self.backoff = 1.0

    def begin(self, work, steps):
        """Before a kernel call of `steps` steps whose largest force loop makes `work` pair
        evaluations: set the kernels' threshold; returns what end() needs (None: nothing to
        time). The other choice is tried only on calls expected to take under PROBE_MAX
        seconds: a game's frames, not a long run in one call, pay for a trial."""
        # the machine's thread limit, not numba.get_num_threads(): that call costs 1.2 us
        if self.mode != "auto" or work < PARALLEL_MIN_PAIRS or numba.config.NUMBA_NUM_THREADS < 2:
            return None
        if not 0.5 <= work / self.work <= 2.0:            # another scene: measure afresh
            self.work = work
            self._measure_afresh()
            self.settle = 2            # its first calls load kernels and build tables: untimed
        now = time.perf_counter()
        cost = self.cost[self.threaded]
        short = (cost if cost < np.inf else self.cost[not self.threaded]) * steps < PROBE_MAX
        if not short:          # no trial inside one call: threads unless measured slower,
            # or other work holds the cores they need
            slower = np.inf > self.cost[True] > self.cost[False]
            threaded = not (slower or _crowded())
            if threaded != self.threaded:
                self.threaded, self.recent = threaded, []
        elif not self.trial and now >= self.probe_at:
            if self.threaded or not _crowded():
                self.trial, self.trial_cost = TRIAL_CALLS, np.inf
            else:
                self.probe_at = now + self.backoff      # threads would wait: not now
        probe = short and self.trial > 0
        use = self.threaded != probe
        self.min_pairs[0] = PARALLEL_MIN_PAIRS if use else NEVER
        return use, probe, now

    def end(self, token, steps):
        """After the call: book its time per step, and choose."""
        if token is None or steps <= 0:
            return
        if self.settle:
            self.settle -= 1
            return
        use, probe, start = token
        now = time.perf_counter()
        per_step = (now - start) / steps
        if probe:
            self.trial_cost = min(self.trial_cost, per_step)
            self.trial -= 1
            if self.trial:
                return
            self.cost[use] = self.trial_cost
            if self.trial_cost < self.cost[not use]:
                self.threaded = use
                self.recent = [self.trial_cost]
                self.backoff = 1.0
            else:
                self.backoff = min(2.0 * self.backoff, 60.0)
            self.probe_at = now + self.backoff
            return
        before = self.cost[use]
        self.recent = (self.recent + [per_step])[-TRIAL_CALLS:]
        self.cost[use] = min(self.recent)
        if self.cost[use] > 4.0 * before:     # its last calls all 4x slower: look again now
            self.probe_at = now
