"""Numba's start without ``scipy.linalg``: our compiled code needs no BLAS.

The first call of any compiled function loads numba's CPU registries; one of them,
``numba/np/arraymath.py``, runs ``_HAVE_BLAS = _check_blas()`` at import (numba 0.68.1 as
installed: ``numba/np/arraymath.py`` lines 36-45; github.com/numba/numba at 5340f05: lines 35-44),
which imports ``scipy.linalg.cython_blas`` (``ensure_blas``, ``numba/np/linalg.py`` line 115
installed, line 57 at 5340f05) and so the whole of ``scipy.linalg``: about
0.17 s of CPU in every fresh process, 20-25 % of numba's own start (the floor of ``aiauv bench``'s
end_to_end part). ``_check_blas`` treats an ``ImportError`` as "no BLAS", and the flag it sets
only chooses how ``np.correlate`` and ``np.convolve`` form inner products inside compiled code
(``_get_inner_prod``, the flag's only reader): BLAS ``np.dot`` or a loop. None of our kernels,
laws or controllers calls either, so their results are unchanged (bit for bit; tested).

:func:`install` (called when this module is imported, first thing in ``aiauv_pin/__init__.py``)
adds an import finder (:data:`sys.meta_path`, the import system's documented hook)
that refuses ``scipy.linalg`` to that one caller, ``_check_blas`` of ``numba.np.arraymath``, once;
it then removes itself. Every other import of ``scipy.linalg`` (ours, the user's, numba's own
``ensure_blas`` / ``ensure_lapack`` when compiled code calls ``np.dot`` or ``np.linalg``) is
untouched. If ``scipy.linalg`` is already imported, numba finds it and nothing changes. A user's
compiled code calling ``np.correlate`` or ``np.convolve`` on floats then gets numba's loop instead
of BLAS's ``dot`` (equal up to rounding); ``AIAUV_NUMBA_BLAS_CHECK=1`` keeps numba's check.
"""

from __future__ import annotations

import os
import sys

#: The frame (module, function) whose import of ``scipy.linalg`` is refused.
_CALLER = ("numba.np.arraymath", "_check_blas")


class _SkipNumbaBlasCheck:
    """Import finder refusing ``scipy.linalg`` to numba's ``_check_blas`` only (see the module)."""

    def find_spec(self, name, path=None, target=None):
        if name != "scipy.linalg":
            return None
        frame = sys._getframe(1)
        while frame is not None:
            code = frame.f_code
            if code.co_name == _CALLER[1] and frame.f_globals.get("__name__") == _CALLER[0]:
                remove()
                raise ModuleNotFoundError(
                    "scipy.linalg skipped for numba's BLAS check (aiauv_pin._internal.numba_blas)",
                    name=name,
                )
            frame = frame.f_back
        return None


_FINDER = _SkipNumbaBlasCheck()


def install() -> None:
    """Add the finder, unless numba's registries or ``scipy.linalg`` are loaded already or
    ``AIAUV_NUMBA_BLAS_CHECK=1``."""
    if os.environ.get("AIAUV_NUMBA_BLAS_CHECK") == "1":
        return
    if "numba.np.arraymath" in sys.modules or "scipy.linalg" in sys.modules:
        return
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)


def remove() -> None:
    """Remove the finder (after its one refusal)."""
    if _FINDER in sys.meta_path:
        sys.meta_path.remove(_FINDER)


install()
