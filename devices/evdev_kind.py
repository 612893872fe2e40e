"""`driver: evdev`: a Linux force-feedback joystick or wheel driven by the kernel's own driver
(hid-pidff, hid-lg4ff, ...) through evdev (its driver: hapticgraph.devices.evdev_ff; its inputs
named as a HID device's: hapticgraph.devices.evdev_layout).

    wheel: {driver: evdev, match: {name: "G29"}, max_force: 0.4}
    left:  {driver: evdev, match: {name: "SideWinder", index: 0}}
    right: {driver: evdev, match: {name: "SideWinder", index: 1}}

`max_force` is a fraction of the device's full scale (0 … 1, default 0.5): the patch's force
reaches the device as that fraction. The device is looked for when the patch loads (its ports
are its capabilities'), so a patch naming one loads only while it is connected.
"""
from .driver_kind import NUMBER, DriverKind, attach, attached, match_setting
from .errors import DeviceError
from . import evdev_layout
from .evdev_layout import MATCH_KEYS, EvdevMatchError, connected, find, no_kernel_driver


class EvdevKind(DriverKind):
    """A kernel force-feedback device: its inputs are its evdev capabilities, its force one
    constant-force effect."""

    name = "evdev"
    required = ("match",)
    carries = (("evdev_layout", "match"),)

    def settings(self):
        return {"max_force": {**NUMBER, "exclusiveMinimum": 0, "maximum": 1.0, "default": 0.5,
                              "description": "the largest force sent, a fraction of the device's full scale; "
                                            "the patch's force is in that unit"},
                "match": match_setting("the input device (/dev/input/event*)",
                                       serial={"type": "string", "description": "its serial (evdev uniq)"},
                                       path={"type": "string", "minLength": 1,
                                             "description": "its node, e.g. /dev/input/event7"}),
                "axis": {"enum": ["x", "y"], "default": "x",
                         "description": "the axis the force pushes along (a wheel's is x)"},
                "slew": {**NUMBER, "exclusiveMinimum": 0, "maximum": 1000, "default": 20.0,
                         "description": "how fast the force may rise, in full scales per second"},
                "watchdog": {**NUMBER, "minimum": 0, "maximum": 10, "default": 0.25,
                             "description": "the force ends this long [s] after the patch stops sending it "
                                            "(a stalled process); 0: never"},
                "autocenter": {**NUMBER, "minimum": 0, "maximum": 1, "default": 1.0,
                               "description": "the autocentring left when playing ends (0 … 1 of full; off "
                                              "while playing)"}}

    def check(self, name, spec, base, problems):
        match = spec.get("match")
        if not isinstance(match, dict) or not match or any(k not in MATCH_KEYS for k in match):
            return                            # the schema says so
        try:
            module = evdev_layout.evdev_module()
            device, layout = find(match, module)
        except EvdevMatchError as exc:        # no such device: is it a HID PID device the kernel does not drive?
            said = _undriven(match, module)
            problems.add(spec.lines.get("match", spec.line), f"device {name!r}: {exc}"
                         + "".join(f"; {line}" for line in said))
            return
        except DeviceError as exc:            # python-evdev missing
            problems.add(spec.lines.get("match", spec.line), f"device {name!r}: {exc}")
            return
        device.close()
        attach(spec, "evdev_layout", layout)

    def axes(self, spec):
        layout = attached(spec, "evdev_layout")
        return list(layout.ports) if layout is not None else []

    def open(self, name, spec, patch):
        from .evdev_ff import EvdevDriver     # the driver's module (the engine, numpy): when opened
        if not isinstance(spec.get("match"), dict):
            raise DeviceError(f"device {name!r}: driver evdev needs `match:` (vendor, product, name, serial, "
                              f"path or index)")
        module = evdev_layout.evdev_module()      # looked up here: the tests replace it
        device, layout = find(spec["match"], module)
        expected = attached(spec, "evdev_layout")
        if expected is not None and expected.ports != layout.ports:
            device.close()
            raise DeviceError(f"device {name!r}: {layout.name!r} at {layout.path} has other inputs than when "
                              f"the patch loaded (another device took its place?); load the patch again")
        try:
            return EvdevDriver(name, spec, device, layout, module)
        except DeviceError:
            device.close()
            raise


def _hid_devices():
    """hidapi's devices with their descriptors read (hapticgraph.devices.hid_match.connected);
    [] without hidapi. hid-tools (75 ms to import) is imported only when a device is not found."""
    from . import hid_match
    try:
        return hid_match.connected()
    except DeviceError:
        return []


def _undriven(match, module):
    """One line for each HID PID device that `match` names and the kernel gives no force feedback."""
    def named(d):
        return (match.get("vendor", d.get("vendor_id")) == d.get("vendor_id")
                and match.get("product", d.get("product_id")) == d.get("product_id")
                and str(match.get("name", "")).lower() in
                f"{d.get('manufacturer_string') or ''} {d.get('product_string') or ''}".lower())
    return no_kernel_driver([d for d in _hid_devices() if named(d)], connected(module))


__all__ = ["EvdevKind"]
