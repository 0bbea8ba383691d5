"""2-D numeric arrays of MATLAB ``.mat`` files, refused with a clear message unless they
are real numbers in rows and columns.

Refused (:class:`~inins.exceptions.InputError` naming the file and the key that names
the variable): a file scipy cannot read, a missing variable (the ones present listed),
text, cells, structs, complex or boolean values, an array that is not 2-D, fewer rows
than the reader needs, a column index outside the array.
"""

import numpy as np

from inins.exceptions import InputError


def _load(path):
    import scipy.io  # only for a .mat input

    try:
        return scipy.io.loadmat(path)
    except MemoryError:
        raise
    except Exception as exc:  # scipy raises many kinds on a damaged file
        raise InputError(
            f"cannot read the .mat file ({type(exc).__name__}: {exc})", source=path
        ) from None


def mat_array(path, variable, key, min_rows=1):
    """The 2-D float array ``variable`` of a .mat file (module docstring).

    Parameters
    ----------
    path : str or Path
    variable : str
        The variable's name.
    key : str
        The scenario key naming the variable (in messages).
    min_rows : int
        Fewest rows accepted.

    Returns
    -------
    ndarray of float64, shape (n, k)
    """
    path = str(path)
    mat = _load(path)
    if variable not in mat:
        names = sorted(k for k in mat if not k.startswith("__"))
        raise InputError(f"no variable {variable!r} (has {names})", source=path, key=key)
    a = np.asarray(mat[variable])
    kind = a.dtype.kind
    if kind not in "fiu":
        what = {
            "c": "complex numbers",
            "U": "text",
            "S": "text",
            "O": "cells or structs",
            "b": "true/false values",
            "V": "a struct",
        }.get(kind, f"values of type {a.dtype}")
        raise InputError(f"{variable!r} holds {what}, not real numbers", source=path, key=key)
    if a.ndim != 2:
        raise InputError(
            f"{variable!r} has shape {a.shape}: not a 2-D array (rows x columns)",
            source=path,
            key=key,
        )
    if a.shape[0] < min_rows:
        raise InputError(
            f"{variable!r} has {a.shape[0]} rows, at least {min_rows} needed"
            + (" (transposed?)" if a.shape[1] >= min_rows else ""),
            source=path,
            key=key,
        )
    return a.astype(float)


def columns(a, cols, path, variable, key):
    """Columns ``cols`` (0-based) of ``a``, (n, len(cols)); an index outside is bad input."""
    for c in cols:
        if not 0 <= int(c) < a.shape[1]:
            raise InputError(
                f"column {c} is outside {variable!r}, which has {a.shape[1]} columns (0-based)",
                source=str(path),
                key=key,
            )
    return a[:, [int(c) for c in cols]]
