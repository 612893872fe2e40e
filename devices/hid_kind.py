"""`driver: hid`: a USB HID device described by a profile (hapticgraph.devices.hid_profiles; its
driver: hapticgraph.devices.hid)."""
import os

from ..graph.errors import PatchError
from .driver_kind import DriverKind, attach, attached
from .hid_profiles import find_profile, load_profile, profile_of, shipped_profiles
from .limits import check_limit


class HidKind(DriverKind):
    """A HID device: its axes and buttons, and its force output, are its profile's."""

    name = "hid"
    required = ("profile",)
    carries = (("hid_profile", "profile"),)

    def settings(self):
        usb_id = {"type": "integer", "minimum": 0, "maximum": 0xFFFF}
        return {**super().settings(),
                "profile": {"type": "string", "minLength": 1,
                            "description": "a shipped HID profile's name (gamepad, mouse, haptic_1dof) "
                                           "or a profile .yaml file beside the patch"},
                "vendor_id": {**usb_id, "description": "USB vendor id, if not the profile's"},
                "product_id": {**usb_id, "description": "USB product id, if not the profile's"},
                "serial": {"type": "string", "description": "open the device with this serial number"},
                "path": {"type": "string", "minLength": 1,
                         "description": "open the device at this hidapi path (`hapticgraph devices` lists them)"}}

    def check(self, name, spec, base, problems):
        """Load the entry's profile, report its problems (an unknown profile at the patch's line, a
        bad one at the profile's FILE:LINE) and attach it to the entry as `hid_profile`."""
        ref = spec.get("profile")
        if not isinstance(ref, str):
            return
        line = spec.lines.get("profile", spec.line)
        path = find_profile(ref, base)
        if path is None:
            known = ", ".join(shipped_profiles()) or "none"
            problems.add(line, f"device {name!r}: no HID profile {ref!r} (shipped: {known}; "
                               f"or a .yaml file beside the patch)")
            return
        try:
            profile = load_profile(path)
        except PatchError as exc:
            problems.add(line, f"device {name!r}: HID profile {ref!r} has {len(exc.problems)} problem(s), "
                               f"listed at its own file and lines")
            problems.problems.extend(exc.problems)
            return
        attach(spec, "hid_profile", profile)
        if profile.output is not None:
            check_limit(spec, name, profile.max_force, f"the bound its profile {profile.name!r} states", problems)

    def axes(self, spec):
        profile = profile_of(spec)
        return list(profile.ports) if profile is not None else []

    def open(self, name, spec, patch):
        from .hid import HidDriver       # the driver's module (hidapi, the engine): when opened
        # the profile the loader attached (its file relative to the patch) unless a setting names another
        return HidDriver(name, spec, profile=attached(spec, "hid_profile"), base=os.getcwd())


__all__ = ["HidKind"]
