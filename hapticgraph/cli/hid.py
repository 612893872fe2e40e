"""`hapticgraph hid describe FILE [--json]` and `hapticgraph hid profile DEVICE_OR_FILE`: a HID
report descriptor read (hapticgraph.devices.hid_recording), parsed and named
(hapticgraph.devices.hid_descriptor), printed. A file that cannot be read is one
`FILE[:LINE]: message` line on stderr and exit status 2."""
import json
import sys

from ..devices.hid_descriptor import DescriptorError, as_json, describe_lines, parse
from ..devices.hid_recording import RecordingError, read_descriptor


def _read(path):
    """(Descriptor, title) of a descriptor file."""
    data, title = read_descriptor(path)
    try:
        return parse(data), title
    except DescriptorError as exc:
        raise RecordingError(f"{path}: {exc}") from None


def _describe(args):
    desc, title = _read(args.file)
    if args.json:
        json.dump(as_json(desc), sys.stdout, indent=1)
        print()
    else:
        print("\n".join(describe_lines(desc, title)))
    return 0


def cmd_hid(args):
    try:
        if args.hid_command == "describe":
            return _describe(args)
        raise RecordingError(f"{args.device}: hid profile is not there yet")
    except RecordingError as exc:
        print(exc, file=sys.stderr)
        return 2


__all__ = ["cmd_hid"]
