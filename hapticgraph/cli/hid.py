"""`hapticgraph hid describe FILE [--json]` and `hapticgraph hid profile DEVICE_OR_FILE`: a HID
report descriptor read (hapticgraph.devices.hid_recording, or a connected device through
hapticgraph.devices.hid_sources), parsed and named (hapticgraph.devices.hid_descriptor), and
printed, or written out as a commented profile to edit (hapticgraph.devices.hid_profile_text).
A file that cannot be read, or a device that is not there, is one `FILE[:LINE]: message` line on
stderr and exit status 2."""
import json
import sys

from ..devices.errors import DeviceError
from ..devices.hid_descriptor import DescriptorError, as_json, describe_lines, parse
from ..devices.hid_profile_text import profile_text
from ..devices.hid_recording import RecordingError, read_descriptor
from ..devices.hid_sources import descriptor_source


def _describe(args):
    data, title = read_descriptor(args.file)
    try:
        desc = parse(data)
    except DescriptorError as exc:
        raise RecordingError(f"{args.file}: {exc}") from None
    if args.json:
        json.dump(as_json(desc), sys.stdout, indent=1)
        print()
    else:
        print("\n".join(describe_lines(desc, title)))
    return 0


def _profile(args):
    desc, title, ids, name = descriptor_source(args.device)
    print(profile_text(desc, args.device, title, ids, name or None), end="")
    return 0


def cmd_hid(args):
    try:
        return _describe(args) if args.hid_command == "describe" else _profile(args)
    except RecordingError as exc:
        print(exc, file=sys.stderr)
        return 2
    except DeviceError as exc:
        print(f"{args.device}: {exc}", file=sys.stderr)
        return 2


__all__ = ["cmd_hid"]
