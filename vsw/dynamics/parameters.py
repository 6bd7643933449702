"""Validation of parameter values against a model's generated parameter table.

Every model's table (``generated/<model>/params.py::PARAMETERS``) gives each parameter an
open interval and the reason for it; nothing is retyped here. Inputs become arrays in one
place, :func:`_as_float_array`, which rejects masked arrays that mask any value.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from vsw.runtime.errors import VswInputError

__all__ = ["as_float_array", "beyond_computed", "check_parameter", "check_positive"]


def _format_value(value: object, cli_degrees: bool) -> str:
    """A short human form of a scalar value; angles also in degrees (the CLI's unit)."""
    if isinstance(value, (float, np.floating)) and cli_degrees and math.isfinite(value):
        return f"{value:.6g} rad ({math.degrees(value):.6g} deg)"
    if isinstance(value, (float, np.floating)):
        return f"{value:.6g}"
    return repr(value)


def as_float_array(name: str, value: object, reason: str) -> np.ndarray:
    """``value`` as a float array; anything that is not a real number raises VswInputError."""
    # bool is an int subclass and strings convert with dtype=float: both are rejected on purpose.
    # A masked array exists only once numpy.ma is imported: not importing it to ask (7 ms
    # of a command's start) changes no answer.
    ma = sys.modules.get("numpy.ma")
    if ma is not None and isinstance(value, ma.MaskedArray) and ma.getmaskarray(value).any():
        # np.asarray would silently drop the mask and compute with the hidden values.
        count = int(ma.getmaskarray(value).sum())
        raise VswInputError(
            f"{name} is a masked array with {count} masked value(s), which would be computed "
            f"as if unmasked; pass the values to use, e.g. {name}.compressed() or "
            f"{name}.filled(...)"
        )
    raw = np.asarray(value)
    if raw.dtype.kind not in "iuf":
        raise VswInputError(f"{name} = {value!r} is not a real number; {reason}")
    return raw.astype(float, copy=False)


def check_parameter(name: str, value: object, table: tuple) -> np.ndarray:
    """Validate one model parameter against the open interval of its generated table.

    Parameters
    ----------
    name : str
        Parameter name as in the table (the ILE's: ``beta``, ``theta_II``, ``phi0``).
    value : float or array_like
        Value(s) in the table's units (radians for angles).
    table : tuple of generated Parameter records
        The model's table (``generated.<model>.params.PARAMETERS``).

    Returns
    -------
    numpy.ndarray
        ``value`` as a float array of the same shape.

    Raises
    ------
    VswInputError
        One line naming the parameter, the first offending value and the violated condition
        with the table's reason (which cites the paper's equation where there is one).
    """
    p = next(r for r in table if r.name == name)
    arr = as_float_array(name, value, p.reason)
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(arr) & (arr > p.lower) & (arr < p.upper))
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if arr.ndim else ()
        where = f"{name}[{', '.join(map(str, index))}]" if index else name
        bad_value = float(arr[index])
        shown = _format_value(bad_value, p.cli_degrees)
        if not math.isfinite(bad_value):
            condition = "must be finite"
        else:
            condition = f"violates {p.lower:.6g} < {name} < {p.upper:.6g}"
        raise VswInputError(f"{where} = {shown} {condition}: {p.reason}")
    computed = p.computed
    if computed is not None:
        outside = ~((arr >= computed[0]) & (arr <= computed[1]))
        if np.any(outside):
            index = tuple(int(i) for i in np.argwhere(outside)[0]) if arr.ndim else ()
            where = f"{name}[{', '.join(map(str, index))}]" if index else name
            shown = _format_value(float(arr[index]), p.cli_degrees)
            raise VswInputError(f"{where} = {shown} {beyond_computed(p)}")
    return arr


def beyond_computed(p) -> str:
    """The end of the message refusing a valid value outside what vsw computes for
    parameter ``p`` (its table's ``computed`` interval and the reason)."""
    low, high = p.computed
    return (
        f"is outside {low:.6g} <= {p.name} <= {high:.6g}, the values vsw computes for it: "
        f"{p.computed_reason}"
    )


def check_positive(name: str, value: object, reason: str) -> np.ndarray:
    """Validate a positive finite quantity (a scale, q0, ...); same error style as parameters.

    Parameters
    ----------
    name : str
        Name used in the message.
    value : float or array_like
    reason : str
        Why it must be positive (appended to the message).

    Returns
    -------
    numpy.ndarray
    """
    arr = as_float_array(name, value, reason)
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(arr) & (arr > 0))
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if arr.ndim else ()
        bad_value = float(arr[index])
        condition = "must be finite" if not math.isfinite(bad_value) else "must be > 0"
        raise VswInputError(f"{name} = {bad_value:.6g} {condition}: {reason}")
    return arr
