"""`driver: hid`: a USB HID device, described by one of

    profile: gamepad | my_pad.yaml       a profile (hapticgraph.devices.hid_profiles): names, ranges, scaling,
                                          the force output and its limit
    recording: take.hid                  a hid-recorder recording: its descriptor, its reports played at their times
    match: {vendor: 0x045e, product: 0x001b} | {name: "SideWinder"} | {usage: joystick, index: 1}
                                          a connected device, read from its own report descriptor

(its driver: hapticgraph.devices.hid). Without a profile the ports are named from the report
descriptor (hapticgraph.devices.hid_descriptor): x is the haptic block's x, then y, rz, slider,
hat_x, hat_y, hat, button1, ... A `match:` device is looked for when the patch loads: its ports
are its descriptor's, so a patch naming one loads only while it is connected.
"""
import os

from ..graph.errors import PatchError
from .driver_kind import USB_ID, DriverKind, attach, attached, match_setting
from .errors import DeviceError
from .hid_profiles import find_profile, load_profile, profile_of, shipped_profiles
from .limits import check_limit

SOURCES = ("profile", "recording", "match")


def _layout_module():
    """hapticgraph.devices.hid_sources: hid-tools (its usage tables take 75 ms to import) is
    imported only for an entry that reads a descriptor, not for every patch that loads."""
    from . import hid_sources
    return hid_sources


class HidKind(DriverKind):
    """A HID device: its axes and buttons, and its force output, are its profile's or its
    descriptor's."""

    name = "hid"
    carries = (("hid_profile", "profile"), ("hid_layout", "recording"), ("hid_layout", "match"),
               ("hid_path", "match"))

    def settings(self):
        return {**super().settings(),
                "profile": {"type": "string", "minLength": 1,
                            "description": "a shipped HID profile's name (gamepad, mouse, haptic_1dof) "
                                           "or a profile .yaml file beside the patch"},
                "recording": {"type": "string", "minLength": 1,
                              "description": "a hid-recorder recording (.hid) beside the patch, played "
                                             "through the device's own descriptor"},
                "match": match_setting("a connected device, named from its report descriptor",
                                       serial={"type": "string"},
                                       usage={"type": "string", "minLength": 1,
                                              "description": "a top-level collection: joystick, gamepad, "
                                                             "mouse, keyboard, multi_axis, consumer"}),
                "vendor_id": {**USB_ID, "description": "USB vendor id, if not the profile's"},
                "product_id": {**USB_ID, "description": "USB product id, if not the profile's"},
                "serial": {"type": "string", "description": "open the device with this serial number"},
                "path": {"type": "string", "minLength": 1,
                         "description": "open the device at this hidapi path (`hapticgraph devices` lists them)"}}

    def check(self, name, spec, base, problems):
        """Load the entry's profile, recording or matched device, report its problems (an unknown
        profile at the patch's line, a bad one at the profile's FILE:LINE, a bad recording at its
        own) and attach what it gave to the entry."""
        wrong = _sources_problem(name, spec)
        if wrong is not None:
            problems.add(spec.line, wrong)
            return
        given = [k for k in SOURCES if k in spec]
        line = spec.lines.get(given[0], spec.line)
        if given[0] == "profile":
            self._check_profile(name, spec, base, problems, line)
        elif given[0] == "recording" and isinstance(spec["recording"], str):
            self._check_recording(name, spec, base, problems, line)
        elif given[0] == "match" and isinstance(spec["match"], dict) and spec["match"]:
            self._check_match(name, spec, problems, line)

    def _check_profile(self, name, spec, base, problems, line):
        ref = spec.get("profile")
        if not isinstance(ref, str):
            return
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

    def _check_recording(self, name, spec, base, problems, line):
        sources = _layout_module()
        try:
            layout, _ = sources.from_recording(spec["recording"], base)
        except ValueError as exc:                 # RecordingError, DescriptorError: FILE[:LINE]: message
            problems.add(line, f"device {name!r}: recording {spec['recording']!r}: {exc}")
            return
        attach(spec, "hid_layout", layout)

    def _check_match(self, name, spec, problems, line):
        sources = _layout_module()
        try:
            layout, path = sources.from_match(spec["match"])
        except DeviceError as exc:               # MatchError; hidapi missing
            problems.add(line, f"device {name!r}: {exc}")
            return
        attach(spec, "hid_layout", layout)
        attach(spec, "hid_path", path)

    def axes(self, spec):
        if "profile" in spec:
            profile = profile_of(spec)
            return list(profile.ports) if profile is not None else []
        layout = attached(spec, "hid_layout")
        if layout is None and isinstance(spec.get("recording"), str):
            try:
                layout, _ = _layout_module().from_recording(spec["recording"])
            except ValueError:
                return []
        return list(layout.ports) if layout is not None else []

    def open(self, name, spec, patch):
        from .hid import HidDriver       # the driver's module (hidapi, the engine): when opened
        base = os.path.dirname(os.path.abspath(patch.file)) if patch.file else os.getcwd()
        wrong = _sources_problem(name, spec)     # `--device NAME=hid` over another driver's entry
        if wrong is not None:
            raise DeviceError(wrong)
        if "profile" in spec:
            # the profile the loader attached (its file relative to the patch) unless a setting names another
            return HidDriver(name, spec, profile=attached(spec, "hid_profile"), base=os.getcwd())
        layout, transport = _layout_module().open_source(name, spec, base)
        return HidDriver(name, spec, transport=transport, profile=layout)


def _sources_problem(name, spec):
    """What is wrong with an entry that names not exactly one of SOURCES, or None."""
    given = [k for k in SOURCES if k in spec]
    if len(given) == 1:
        return None
    what = "one of" if not given else f"only one of (it has {' and '.join(given)})"
    return (f"device {name!r}: driver hid needs {what} 'profile' (a profile's name or file), 'recording' "
            f"(a hid-recorder file) or 'match' (a connected device)")


__all__ = ["HidKind"]
