"""Bounds on the force a device is sent, shared by every driver: the ceiling no device may state,
the simulated device's own bound, and the checks of an entry's `max_force` against a bound (at
load, as a problem at its line; when a driver opens, as a DeviceError)."""
import math

from .errors import DeviceError

FORCE_CEILING = 1000.0       # N: no device (a profile) may state more; the patch schema's bound on max_force
SIMULATED_MAX_FORCE = 50.0   # N: the simulated device's bound (see hapticgraph.devices.simulated)


def is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_limit(spec, name, bound, what, problems):
    """At load: an entry's max_force may not exceed its device's bound (a number > 0 is the
    schema's to check)."""
    value = spec.get("max_force")
    if is_number(value) and 0 < value <= FORCE_CEILING and value > bound:
        problems.add(spec.lines.get("max_force", spec.line),
                     f"device {name!r}: max_force {value:g} N is above {what}, {bound:g} N")


def force_limit(name, driver, value, bound, what):
    """When a driver opens: a device's max_force [N], checked: a finite number > 0 and at most
    `bound` (DeviceError)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise DeviceError(f"device {name!r} ({driver}): max_force {value!r} must be a finite number of newtons > 0")
    if value > bound:
        raise DeviceError(f"device {name!r} ({driver}): max_force {value:g} N is above {what}, {bound:g} N")
    return float(value)


def block_force(force, max_force):
    """The one force a driver sends for a block: its last sample, 0 if it is not finite (or the
    block is empty), clamped to ±max_force."""
    f = float(force[-1]) if len(force) else 0.0
    if not math.isfinite(f):
        f = 0.0
    return min(max(f, -max_force), max_force)


__all__ = ["FORCE_CEILING", "SIMULATED_MAX_FORCE", "block_force", "check_limit", "force_limit", "is_number"]
