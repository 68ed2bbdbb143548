"""A kernel function compiled by the system's C compiler and called as a Python extension.

numba types and lowers a kernel at about a millisecond per statement (4-8 s a plant kernel);
the same statements translated to C (:mod:`pendc.native.translate`) compile in a few tenths
of a second with ``cc -O2`` and run at least as fast. :class:`NativeFunction` is a drop-in for
a numba dispatcher: it specializes on the argument types of each call (arrays by element type
and dimensions), compiles each specialization once into the cache folder (named by the hash of
its source, types, translator and of the compiler and machine, since ``-march=native`` code is
the host's), and releases the GIL while the kernel runs. A source the translator does not know, or an argument
it does not take (another dtype), runs on numba from the same source, with a warning.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.machinery
import importlib.util
import os
import platform
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import threading
import warnings
import weakref
from pathlib import Path

import numpy as np

from ..codegen import cache_dir, load_source
from ..errors import PendcError
from .emit import c_args, c_params, translate
from .prelude import PRELUDE
from .syntax import signature
from .types import BOOL, C_TYPE, FLOAT, INT, ArrayType, Untranslatable

# no contraction into fused multiply-adds and wrapping int64: numba's bits; errno never read. The
# dynamic cost model lets -O2 vectorise loops behind a runtime alias check (the extremes' loop)
FLAGS = ("-O2", "-fvect-cost-model=dynamic", "-march=native", "-fwrapv", "-fno-strict-aliasing",
         "-ffp-contract=off", "-fno-math-errno", "-fPIC", "-shared", "-w")
BACKENDS = ("native", "numba")
_ELEMENTS = {"i8": INT, "f8": FLOAT, "b1": BOOL}
_FORMATS = {INT: (8, "lq"), FLOAT: (8, "d"), BOOL: (1, "?")}
_DISPATCHERS: weakref.WeakValueDictionary = weakref.WeakValueDictionary()


@functools.cache
def toolchain() -> tuple | None:
    """(C compiler, Python's include folder, tag of compiler and machine), or None without one."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    include = sysconfig.get_paths().get("include", "")
    if not cc or not shutil.which(cc) or not Path(include, "Python.h").exists():
        return None
    version = _compiler_version(cc)
    if version is None:
        return None
    flags = ""
    try:
        flags = next((line for line in Path("/proc/cpuinfo").read_text().splitlines() if line.startswith("flags")), "")
    except OSError:
        pass
    tag = hashlib.sha256("\n".join([cc, version, platform.machine(), flags, sys.version, " ".join(FLAGS)]).encode())
    tag = tag.hexdigest()[:16]
    # a compiler that refuses a flag (-march=native, say) must not make every kernel fall back
    # with a warning: an extension is compiled once per toolchain, and without it numba is used
    marker = cache_dir("native") / f"toolchain-{tag}.ok"
    if not marker.exists():
        with tempfile.TemporaryDirectory() as folder:
            probe = Path(folder, "probe.c")
            probe.write_text("#include <Python.h>\nPyMODINIT_FUNC PyInit_probe(void) { return NULL; }\n")
            try:
                done = subprocess.run([cc, *FLAGS, f"-I{include}", str(probe), "-o", str(probe.with_suffix(".so"))],
                                      capture_output=True, timeout=120)
            except (OSError, subprocess.SubprocessError):
                return None
            if done.returncode != 0:
                return None
        marker.touch()
    return cc, include, tag


@functools.cache
def _compiler_version(cc: str) -> str | None:
    try:
        return subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return None


# Python.h as the extension wrapper includes it; with the prelude's C headers, what every kernel's C
# includes. Parsing Python.h is a third of a small kernel's compile (0.10 of 0.35 s), so GCC reads
# them precompiled (made once per toolchain beside the kernels, with the kernels' flags; Python.h
# first, as its manual asks). GCC falls back to the text of a precompiled header it cannot use: the
# objects are the same either way.
PYTHON_H = "#define PY_SSIZE_T_CLEAN\n#include <Python.h>\n"
HEADERS = PYTHON_H + "".join(line + "\n" for line in PRELUDE.splitlines() if line.startswith("#include"))


def precompiled_prelude() -> tuple:
    """The compiler arguments that include :data:`HEADERS` precompiled, or () (no compiler, not
    GCC, or it could not make the header: kernels then parse their includes as text). Made in the
    cache folder of the moment, so a test's own cache folder gets its own."""
    found = toolchain()
    if found is None or "Free Software Foundation" not in (_compiler_version(found[0]) or ""):
        return ()
    cc, include, tag = found
    header = cache_dir("native") / f"prelude-{tag}.h"
    pch = header.with_name(header.name + ".gch")
    if not (pch.exists() and header.exists()):
        part = f".{os.getpid()}.{threading.get_ident()}.tmp"
        text, made = header.with_name(f".{header.name}{part}"), pch.with_name(f".{pch.name}{part}")
        try:
            text.write_text(HEADERS)
            os.replace(text, header)
            done = subprocess.run([cc, *(f for f in FLAGS if f != "-shared"), f"-I{include}", "-x", "c-header",
                                   str(header), "-o", str(made)], capture_output=True, timeout=120)
            if done.returncode != 0:
                made.unlink(missing_ok=True)
                return ()
            os.replace(made, pch)
        except (OSError, subprocess.SubprocessError):
            return ()
    return ("-include", str(header))


def backend() -> str:
    """``native`` (C) when a C compiler and Python's headers are here, else ``numba``;
    ``PENDC_KERNELS=numba`` chooses numba."""
    wanted = os.environ.get("PENDC_KERNELS", "native")
    if wanted not in BACKENDS:
        raise PendcError(f"PENDC_KERNELS must be one of {', '.join(BACKENDS)}, got {wanted!r}")
    return "native" if wanted == "native" and toolchain() is not None else "numba"


def kernel_function(source: str, prefix: str, name: str = "kernel"):
    """The function ``name`` of the generated module ``source``: compiled by C, or by numba."""
    if backend() == "numba":
        return getattr(load_source(source, prefix), name)
    key = (hashlib.sha256(source.encode()).hexdigest(), prefix, name)
    # one dispatcher per source in a process, as numba's module is imported once (sys.modules)
    fn = _DISPATCHERS.get(key)
    if fn is None:
        fn = _DISPATCHERS[key] = NativeFunction(source, prefix, name)
    return fn


def arg_type(value):
    """The translator's type of one argument (arrays: C-contiguous is checked at the call)."""
    if isinstance(value, np.ndarray):
        elem = _ELEMENTS.get(value.dtype.str[1:]) if value.dtype.isnative else None
        if elem is None:
            raise Untranslatable(f"an array of {value.dtype}")
        return ArrayType(elem, value.ndim)
    if isinstance(value, (bool, np.bool_)):
        return BOOL
    if isinstance(value, (int, np.integer)):
        return INT
    if isinstance(value, (float, np.floating)):
        return FLOAT
    raise Untranslatable(f"an argument of type {type(value).__name__}")


def _plain(value):
    """A NumPy scalar as the Python scalar the extension function takes (arrays unchanged)."""
    if isinstance(value, np.generic):
        return value.item()
    return value


class NativeFunction:
    """The function ``name`` of a generated kernel module, compiled to C per argument types."""

    def __init__(self, source: str, prefix: str, name: str = "kernel"):
        self.source, self.prefix, self.name = source, prefix, name
        self._calls: dict = {}
        self._lock = threading.Lock()
        self._defaults = None
        self._arity = -1
        self._last = None

    def __call__(self, *args):
        # the last specialization checks its own arguments (C, before the kernel runs) and says
        # TypeError or BufferError when they are of other types: then the types are worked out
        call = self._last
        if call is not None and len(args) == self._arity:
            try:
                return call(*args)
            except (TypeError, BufferError):
                pass
        return self._dispatch(args)

    def _dispatch(self, args: tuple):
        if self._defaults is None:
            try:
                self._arity, self._defaults = signature(self.source, self.name)
            except Untranslatable:
                self._defaults = ()
        if len(args) < self._arity:
            args = args + self._defaults[len(self._defaults) - (self._arity - len(args)):]
        try:
            key = tuple(arg_type(a) for a in args)
        except Untranslatable as why:
            return self._numba(why)(*args)
        call = self._calls.get(key)
        if call is None:
            call = self._specialize(key)
        self._last = call
        args = tuple(_plain(a) for a in args)
        try:
            return call(*args)
        except BufferError:
            return self._call_contiguous(call, args)

    def _numba(self, why):
        warnings.warn(f"pendc: kernel {self.prefix} runs on numba: {why}", RuntimeWarning, stacklevel=3)
        return getattr(load_source(self.source, self.prefix), self.name)

    @staticmethod
    def _call_contiguous(call, args):
        # numba takes any layout; here a strided array is copied in, and written back after
        copies = [np.ascontiguousarray(a) if isinstance(a, np.ndarray) else a for a in args]
        result = call(*copies)
        for a, c in zip(args, copies):
            if isinstance(a, np.ndarray) and c is not a and a.flags.writeable:
                a[...] = c
        return result

    def _specialize(self, key: tuple):
        with self._lock:
            if key not in self._calls:
                try:
                    self._calls[key] = compiled_call(self.source, self.name, key)
                except Untranslatable as why:
                    self._calls[key] = self._numba(why)
                except (KeyError, AttributeError, TypeError, ValueError, RecursionError) as bug:
                    # a gap in the translator, not in the kernel: numba still runs it, and says so
                    self._calls[key] = self._numba(f"the translator failed ({type(bug).__name__}: {bug})")
            return self._calls[key]


@functools.cache
def _translator_digest() -> str:
    """Hash of pendc.native's own source files: a changed translator makes new extensions."""
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()


def compiled_call(source: str, name: str, key: tuple):
    """The extension function running ``name`` of ``source`` on arguments of types ``key``
    (translated, compiled and cached on first use)."""
    cc, include, tag = toolchain()
    # named by what it is made from (the source, the entry, the types, the toolchain and this
    # package's own code), so a process that finds it built does not translate again
    made_from = "\n".join([source, name, repr(key), tag, _translator_digest()])
    module = f"pendc_native_{hashlib.sha256(made_from.encode()).hexdigest()[:20]}"
    if module in sys.modules:
        return sys.modules[module].call
    folder = cache_dir("native")
    path = folder / f"{module}.so"
    if not path.exists():
        body, fn = translate(source, name, key)
        text = body + _wrapper(fn, key)
        c_file = folder / f"{module}.c"
        full = text + _module_def(module)
        if not c_file.exists() or c_file.read_text() != full:
            tmp = c_file.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(full)
            os.replace(tmp, c_file)
        out = folder / f"{module}.{os.getpid()}.{threading.get_ident()}.tmp"
        done = subprocess.run([cc, *FLAGS, *precompiled_prelude(), f"-I{include}", str(c_file), "-o", str(out), "-lm"],
                              capture_output=True, text=True)
        if done.returncode != 0:
            out.unlink(missing_ok=True)
            first = (done.stderr.strip().splitlines() or ["no message"])[0]
            raise Untranslatable(f"the C compiler failed on {c_file.name}: {first}")
        os.replace(out, path)
    loader = importlib.machinery.ExtensionFileLoader(module, str(path))
    spec = importlib.util.spec_from_file_location(module, path, loader=loader)
    ext = importlib.util.module_from_spec(spec)
    loader.exec_module(ext)
    sys.modules[module] = ext
    return ext.call


def _wrapper(fn, key: tuple) -> str:
    """C of the METH_FASTCALL function ``call``: arguments checked and unpacked, the kernel
    run without the GIL, its result boxed."""
    names = list(fn.params)
    arrays = sum(isinstance(t, ArrayType) for t in key)
    lines = ["", *PYTHON_H.splitlines(), "",
             "static int take(PyObject *o, Py_buffer *b, Py_ssize_t item, int ndim, const char *formats) {",
             "    if (PyObject_GetBuffer(o, b, PyBUF_RECORDS_RO) < 0) return -1;",
             "    const char *f = b->format ? b->format : \"B\";",
             "    if (*f == '<' || *f == '=' || *f == '@' || *f == '|') f++;",
             "    if (b->ndim != ndim || b->itemsize != item || !*f || f[1] || !strchr(formats, *f)",
             "        || !PyBuffer_IsContiguous(b, 'C')) {",
             "        PyBuffer_Release(b);",
             "        PyErr_SetString(PyExc_BufferError, \"pendc native kernel: an array of another type or layout\");",
             "        return -1;", "    }", "    return 0;", "}", "",
             "static PyObject *call(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {",
             f"    Py_buffer views[{max(arrays, 1)}];", "    int held = 0;", "    PyObject *result = NULL;"]
    for n, t in zip(names, key):
        first = c_params(n, t)[0]
        lines.append(f"    {first} = NULL;" if isinstance(t, ArrayType) else f"    {first};")
    lines += [f"    if (nargs != {len(key)}) {{",
              f"        PyErr_SetString(PyExc_TypeError, \"pendc native kernel: {len(key)} arguments expected\");",
              "        return NULL;", "    }"]
    view_of = {}
    for i, (n, t) in enumerate(zip(names, key)):
        var = c_args(n, t)[0]
        if isinstance(t, ArrayType):
            item, formats = _FORMATS[t.elem]
            view_of[n] = len(view_of)
            lines += [f"    if (take(args[{i}], &views[held], {item}, {t.ndim}, \"{formats}\") < 0) goto done;",
                      f"    {var} = ({C_TYPE[t.elem]} *)views[held++].buf;"]
        elif t == INT:
            # an int or NumPy integer (its __index__); not a bool or float, which numba types apart
            arg = f"args[{i}]"
            lines += [f"    if (!PyIndex_Check({arg}) || PyBool_Check({arg}) || PyFloat_Check({arg})) goto mismatch;",
                      f"    {var} = PyLong_AsLongLong(args[{i}]); if ({var} == -1 && PyErr_Occurred()) goto done;"]
        elif t == FLOAT:
            lines.append(f"    if (!PyFloat_Check(args[{i}])) goto mismatch; {var} = PyFloat_AS_DOUBLE(args[{i}]);")
        else:
            lines.append(f"    if (!PyBool_Check(args[{i}])) goto mismatch; {var} = (args[{i}] == Py_True);")
    flat = []
    for n, t in zip(names, key):
        if isinstance(t, ArrayType):
            flat += [c_args(n, t)[0]] + [f"views[{view_of[n]}].shape[{d}]" for d in range(t.ndim)]
        else:
            flat += c_args(n, t)
    invoke = f"{fn.cname}({', '.join(flat)})"
    raised = ["    if (zero_division) {",
              "        PyErr_SetString(PyExc_ZeroDivisionError, \"division by zero\");", "        goto done;", "    }"]
    if fn.returns is None:
        lines += ["    Py_BEGIN_ALLOW_THREADS", "    zero_division = 0;", f"    {invoke};", "    Py_END_ALLOW_THREADS",
                  *raised, "    result = Py_None; Py_INCREF(result);"]
    else:
        if fn.returns not in (INT, FLOAT, BOOL):
            raise Untranslatable(f"{fn.fdef.name} returns a tuple to Python")
        box = {INT: "PyLong_FromLongLong", FLOAT: "PyFloat_FromDouble", BOOL: "PyBool_FromLong"}[fn.returns]
        lines += [f"    {{ {C_TYPE[fn.returns]} r;", "    Py_BEGIN_ALLOW_THREADS", "    zero_division = 0;",
                  f"    r = {invoke};", "    Py_END_ALLOW_THREADS", *["    " + x for x in raised],
                  f"    result = {box}(r); }}"]
    lines += ["    goto done;", "mismatch:",
              "    PyErr_SetString(PyExc_TypeError, \"pendc native kernel: an argument of another type\");",
              "done:", "    for (int i = 0; i < held; i++) PyBuffer_Release(&views[i]);", "    return result;", "}", ""]
    return "\n".join(lines)


def _module_def(module: str) -> str:
    return (f"static PyMethodDef methods[] = {{{{\"call\", (PyCFunction)(void (*)(void))call, METH_FASTCALL, NULL}},"
            f" {{NULL, NULL, 0, NULL}}}};\n"
            f"static struct PyModuleDef definition = {{PyModuleDef_HEAD_INIT, \"{module}\", NULL, -1, methods}};\n"
            f"PyMODINIT_FUNC PyInit_{module}(void) {{ return PyModule_Create(&definition); }}\n")
