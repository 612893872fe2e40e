"""`driver: serial`: a haptic device on a serial line, described by a wire-protocol profile
(hapticgraph.devices.serial_profiles; its driver: hapticgraph.devices.serial_port)."""
import os

from ..graph.errors import PatchError
from .driver_kind import DriverKind, attach, attached
from .errors import DeviceError
from .limits import check_limit
from .serial_profiles import find_profile, load_profile, shipped_profiles


class SerialKind(DriverKind):
    """A serial haptic device: its axes and its force output are its profile's."""

    name = "serial"
    required = ("profile", "port")
    carries = (("serial_profile", "profile"),)

    def settings(self):
        return {**super().settings(),
                "profile": {"type": "string", "minLength": 1,
                            "description": "a shipped serial profile's name (fader_1dof, pantograph_2dof) "
                                           "or a profile .yaml file beside the patch"},
                "port": {"type": "string", "minLength": 1, "description": "the serial port, e.g. /dev/ttyACM0"},
                "baudrate": {"type": "integer", "minimum": 300, "maximum": 50_000_000,
                             "description": "bits per second, if not the profile's"}}

    def check(self, name, spec, base, problems):
        ref = spec.get("profile")
        if not isinstance(ref, str):
            return
        path = find_profile(ref, base)
        if path is None:
            problems.add(spec.lines.get("profile", spec.line), f"device {name!r}: no serial profile {ref!r} "
                         f"(shipped: {', '.join(shipped_profiles())}; or a .yaml file beside the patch)")
            return
        try:
            profile = load_profile(path)
        except PatchError as exc:
            problems.add(spec.lines.get("profile", spec.line), f"device {name!r}: serial profile {ref!r} has "
                         f"{len(exc.problems)} problem(s), listed at its own file and lines")
            problems.problems.extend(exc.problems)
            return
        attach(spec, "serial_profile", profile)
        check_limit(spec, name, profile.max_force, f"the bound its profile {profile.name!r} states", problems)

    def axes(self, spec):
        profile = attached(spec, "serial_profile")
        return list(profile.ports) if profile is not None else []

    def open(self, name, spec, patch):
        from .serial_port import SerialDriver      # the driver's module (pyserial, the engine): when opened
        profile = attached(spec, "serial_profile")
        if profile is None:
            path = find_profile(str(spec.get("profile", "")), os.path.dirname(os.path.abspath(patch.file)))
            if path is None:
                raise DeviceError(f"device {name!r}: no serial profile {spec.get('profile')!r}")
            profile = load_profile(path)
        return SerialDriver(name, spec, profile)


__all__ = ["SerialKind"]
