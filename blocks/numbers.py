"""Whole numbers written as floats. Where an integer is meant — a cell index, a count, a number of
channels, a length in samples, a byte offset — `2.0` is the integer 2 and `2.5` is refused, naming
the value. One reading, used by the patch loader (through its JSON Schema: every place the schema
calls an integer), `--set`, `--probe` and cell references (`s[2.0]`), device profiles and sweep
files; it lives in the lowest layer so every other can use it."""
import math
import numbers
import re

# the text of a whole number: at most 18 digits (as a cell index), an optional `.0…` fraction
WHOLE_TEXT = r"-?[0-9]{1,18}(?:\.0*)?"
_WHOLE = re.compile(rf"\s*({WHOLE_TEXT})\s*")


def whole_number(value):
    """`value` as an int when it is a whole number: an int (not a bool), a finite float without
    fraction (2.0 -> 2) or such a number's decimal text ("2", "2.0"); ValueError naming the value
    otherwise ("2.5 is not a whole number")."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return int(value)
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        if math.isfinite(value) and float(value).is_integer():
            return int(value)
    elif isinstance(value, str):
        m = _WHOLE.fullmatch(value)
        if m:
            return int(m.group(1).partition(".")[0])
    raise ValueError(f"{value!r} is not a whole number")


def is_whole(value):
    """True if whole_number(value) reads it."""
    try:
        whole_number(value)
    except ValueError:
        return False
    return True


__all__ = ["WHOLE_TEXT", "is_whole", "whole_number"]
