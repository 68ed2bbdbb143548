"""Generated kernels compiled by the system's C compiler instead of numba.

:mod:`pendc.native.translate` types the kernels' Python subset as numba does and prints C with
numba's semantics (:mod:`pendc.native.emit` prints a function); :mod:`pendc.native.build`
compiles it, caches the shared object and calls it as a Python extension function.
``PENDC_KERNELS=numba`` keeps numba, which is also used where no C compiler is found.
"""

from .build import NativeFunction, backend, kernel_function
from .emit import translate
from .types import Untranslatable

__all__ = ["NativeFunction", "Untranslatable", "backend", "kernel_function", "translate"]
