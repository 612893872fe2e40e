"""Device entries (`devices:`): which driver kind each names, its axes, the driver kinds' own
checks, and the blocks bound to each entry."""
from .errors import suggest
from .source import LDict


def driver_of(spec, drivers):
    """The driver kind of a device entry: its `driver:`, else the default kind; None if unknown."""
    name = spec.get("driver") if isinstance(spec, dict) else None
    if name is None:
        return next((k for k in drivers.values() if k.default), None)
    return drivers.get(name) if isinstance(name, str) else None


def device_axes(devices, name, drivers):
    """A device's extra axes and buttons, as its driver kind reads them from its entry."""
    spec = devices.get(name) if isinstance(devices, dict) else None
    kind = driver_of(spec, drivers) if isinstance(spec, dict) else None
    return list(kind.axes(spec)) if kind is not None else []


def check_drivers(devices, drivers, base, problems):
    """Each device entry names a known driver (or there is a default one), which checks the rest."""
    if not isinstance(devices, LDict):
        return
    for name, spec in devices.items():
        if not isinstance(spec, LDict):
            continue
        kind = driver_of(spec, drivers)
        if kind is None:
            given = spec.get("driver")
            known = ", ".join(sorted(drivers)) or "none (the loader was given no driver table)"
            what = (f"unknown driver {given!r}{suggest(str(given), drivers)}" if given is not None
                    else "no driver given, and there is no default one")
            problems.add(spec.lines.get("driver", spec.line), f"device {name!r}: {what}; the drivers are: {known}")
            continue
        kind.check(name, spec, base, problems)


def check_bound_blocks(devices, blocks, problems):
    """Every device reference names a declared device, once."""
    users = {}
    for inst in blocks.values():
        for pname, param in inst.cls.params.items():
            if param.refers != "devices":
                continue
            value = inst.values[pname]
            line = inst.line_of(pname)
            if not value:
                problems.add(line, f"block {inst.name!r} ({inst.cls.type_name}): parameter {pname!r}: "
                                   f"name the device (one of: {', '.join(devices) or 'none declared under devices:'})")
            elif value not in devices:
                problems.add(line, f"block {inst.name!r} ({inst.cls.type_name}): parameter {pname!r}: "
                                   f"no device named {value!r} under devices:{suggest(value, devices)}")
            elif value in users:
                problems.add(line, f"block {inst.name!r}: device {value!r} is already bound to block {users[value]!r}")
            else:
                users[value] = inst.name
