"""MKL PARDISO's sparse Cholesky, for the large Newton systems of the fast solver.

A binding of our own through ctypes (decision 0075): the library comes from the ``mkl`` wheel
(``libmkl_rt`` in the environment's ``lib``), loaded on first use and only by the solver's large
systems. Where it cannot be loaded (no wheel on this platform, a broken install) :func:`available`
is False and the solver keeps SuperLU; nothing else changes.

Contract of :class:`Cholesky`: the sparsity pattern (the upper triangle in CSR, zero-based,
sorted column indices, every diagonal entry present) is analysed once; each :meth:`Cholesky.factor`
then factorises new values on that pattern in place (a factor returned earlier is no longer
valid) and says False, keeping nothing, when the matrix is not positive definite, so the caller
decides with another factorisation. The calls release the GIL (ctypes' foreign calls do), so a
window's event loop runs while a large system factorises. Memory is freed by :meth:`close` or
when the object is collected.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os
import site
import sys
import threading
import weakref

import numpy as np

__all__ = ["Cholesky", "available"]

_SPD = 2  # real symmetric positive definite: a Cholesky factor, no pivoting
_ANALYSE, _FACTOR, _SOLVE, _RELEASE = 11, 22, 33, -1
_RELEASE_FACTOR = 0  # the factor's memory only: the analysis stays for the next phase 22
_NOT_POSITIVE = -4  # "zero pivot, numerical factorization or iterative refinement problem"


@functools.cache
def _library() -> ctypes.CDLL | None:
    """libmkl_rt from the environment's ``lib`` (where the ``mkl`` wheel puts it; the user's base for
    a ``--user`` install), else the system's, or None."""
    names = [path for base in dict.fromkeys((sys.prefix, site.getuserbase()))
             for path in sorted(glob.glob(os.path.join(base, "lib", "libmkl_rt.so*")))]
    names += ["libmkl_rt.so.3", "libmkl_rt.so.2"]
    for path in names:
        try:
            lib = ctypes.CDLL(path)
            lib.pardiso.restype = None
            lib.pardisoinit.restype = None
            return lib
        except (OSError, AttributeError):
            continue
    return None


def available() -> bool:
    """True if PARDISO can be called here."""
    return _library() is not None


def _ptr(a: np.ndarray) -> ctypes.c_void_p:
    return a.ctypes.data_as(ctypes.c_void_p)


def _release(lib, handle: np.ndarray, iparm: np.ndarray, n: int, lock: threading.Lock) -> None:
    """Free a handle's memory (phase -1); called once, by close() or the finaliser."""
    with lock:
        if handle.any():
            _call(lib, handle, iparm, _RELEASE, n, None, None, None, None, None)
            handle[:] = 0


def _call(lib, handle, iparm, phase, n, data, indptr, indices, b, x, perm=None) -> int:
    """One call of ``pardiso`` (one factor, a real SPD matrix, one right-hand side, silent): its error."""
    i32 = ctypes.c_int32
    error = i32(0)
    zero = np.zeros(1)
    lib.pardiso(_ptr(handle), ctypes.byref(i32(1)), ctypes.byref(i32(1)), ctypes.byref(i32(_SPD)),
                ctypes.byref(i32(phase)), ctypes.byref(i32(n)),
                _ptr(data if data is not None else zero), _ptr(indptr if indptr is not None else iparm),
                _ptr(indices if indices is not None else iparm), _ptr(perm) if perm is not None else None,
                ctypes.byref(i32(1)), _ptr(iparm),
                ctypes.byref(i32(0)), _ptr(b if b is not None else zero), _ptr(x if x is not None else zero),
                ctypes.byref(error))
    return int(error.value)


class Cholesky:
    """A positive definite matrix's Cholesky factor by PARDISO on a fixed pattern.

    ``indptr``, ``indices``: the upper triangle (diagonal included) in CSR, zero-based, sorted
    column indices per row. ``ordered``: the rows are already in a fill-reducing order (the
    solver's nested dissection), so PARDISO keeps it instead of running METIS. Raises
    ``RuntimeError`` if PARDISO is not available or rejects the pattern.
    """

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, ordered: bool = True):
        lib = _library()
        if lib is None:
            raise RuntimeError("MKL PARDISO is not available")
        self._lib = lib
        self.n = len(indptr) - 1
        self._indptr = np.ascontiguousarray(indptr, dtype=np.int32)
        self._indices = np.ascontiguousarray(indices, dtype=np.int32)
        self._handle = np.zeros(64, dtype=np.int64)
        self._iparm = np.zeros(64, dtype=np.int32)
        lib.pardisoinit(_ptr(self._handle), ctypes.byref(ctypes.c_int32(_SPD)), _ptr(self._iparm))
        self._iparm[34] = 1  # zero-based indices
        self._iparm[26] = 0  # no matrix checker: the solver's patterns are built sorted
        # no iterative refinement (its default is 2 steps): a solve then costs half (0.11 against 0.24 s at
        # 320,000 unknowns), and SuperLU's and QDLDL's solves, which the solver was made on, refine none
        self._iparm[7] = 0
        self._lock = threading.Lock()
        self._finalizer = weakref.finalize(self, _release, lib, self._handle, self._iparm, self.n, self._lock)
        self.ok = False  # True while a factorisation is held
        perm = None
        if ordered:
            self._iparm[4] = 1  # the caller's order: the identity permutation
            perm = np.arange(self.n, dtype=np.int32)
        dummy = np.zeros(len(self._indices))
        with self._lock:
            err = _call(lib, self._handle, self._iparm, _ANALYSE, self.n, dummy, self._indptr, self._indices,
                        None, None, perm)
        if err != 0:
            self.close()
            raise RuntimeError(f"PARDISO's analysis failed (error {err})")

    @property
    def factor_nnz(self) -> int:
        """Entries of the factor, as the analysis counted them."""
        return int(self._iparm[17])

    def factor(self, data: np.ndarray) -> bool:
        """Factorise the matrix with values ``data`` (in the pattern's order): True, or False if
        it is not positive definite (nothing is held then). Other failures raise RuntimeError."""
        self._data = np.ascontiguousarray(data, dtype=np.float64)  # PARDISO reads it again at solves
        if len(self._data) != len(self._indices):
            raise ValueError("the values do not match the analysed pattern")
        with self._lock:
            err = _call(self._lib, self._handle, self._iparm, _FACTOR, self.n, self._data, self._indptr,
                        self._indices, None, None)
        self.ok = err == 0
        if err == _NOT_POSITIVE:
            return False
        if err != 0:
            raise RuntimeError(f"PARDISO's factorisation failed (error {err})")
        return True

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x with A x = b for the last factorisation."""
        if not self.ok:
            raise RuntimeError("no factorisation is held")
        b = np.ascontiguousarray(b, dtype=np.float64)
        if b.shape != (self.n,):
            raise ValueError(f"the right-hand side has shape {b.shape}, not ({self.n},)")
        x = np.empty(self.n)
        with self._lock:
            err = _call(self._lib, self._handle, self._iparm, _SOLVE, self.n, self._data, self._indptr,
                        self._indices, b, x)
        if err != 0:
            raise RuntimeError(f"PARDISO's solve failed (error {err})")
        return x

    def release_factor(self) -> None:
        """Free the factor's memory now and keep the analysis: the next :meth:`factor` works as
        before, :meth:`solve` raises until then. A large piece's factor is most of its memory,
        and the solver drops it before it assembles the next matrix."""
        with self._lock:
            if self.ok and self._handle.any():
                _call(self._lib, self._handle, self._iparm, _RELEASE_FACTOR, self.n, None, None, None, None, None)
            self.ok = False
            self._data = None

    def close(self) -> None:
        """Free PARDISO's memory for this pattern now."""
        self.ok = False
        self._finalizer()
