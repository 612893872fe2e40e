"""Where the layout of a `driver: hid` entry without a profile comes from:

    stick: {driver: hid, recording: take.hid}          a hid-recorder recording (relative to the patch)
    stick: {driver: hid, match: {vendor: 0x045e}}      a connected device (hapticgraph.devices.hid_match)

Either gives a DescribedDevice (hapticgraph.devices.hid_layout) read from the report descriptor:
the recording's `R:` line, or the device's own. A recording plays its `E:` lines at their times
through a ReplayTransport in virtual time (deterministic: every sample gets the report stamped
at or before it); a matched device is opened by its hidapi path.
"""
import os
import re

from .errors import DeviceError
from .hid_descriptor import DescriptorError, parse
from .hid_layout import DescribedDevice
from .hid_match import MatchError, connected_entry, find, read_descriptor as read_device_descriptor
from .hid_recording import RecordingError, load_recording, read_descriptor
from .hid_transports import HidapiTransport, ReplayTransport


def recording_path(ref, base):
    ref = os.fspath(ref)
    return ref if os.path.isabs(ref) else os.path.join(base or os.getcwd(), ref)


def from_recording(ref, base=None):
    """(DescribedDevice, Recording) of a recording file; RecordingError or DescriptorError."""
    rec = load_recording(recording_path(ref, base))
    layout = DescribedDevice(parse(rec.descriptor), rec.name, rec.vendor_id, rec.product_id, rec.interval(),
                             source=rec.path)
    return layout, rec


def from_match(match):
    """(DescribedDevice, hidapi path) of the connected device `match` names; MatchError."""
    found = find(match)
    layout = DescribedDevice(found.descriptor, found.name, found.info.get("vendor_id", 0),
                             found.info.get("product_id", 0), collection=found.collection, source=str(found.path))
    return layout, found.path


def open_source(name, spec, base=None):
    """(layout, transport) of an entry with `recording:` or `match:`; DeviceError if it cannot be had."""
    if spec.get("recording") is not None:
        try:
            layout, rec = from_recording(spec["recording"], base)
        except (RecordingError, DescriptorError) as exc:
            raise DeviceError(f"device {name!r}: {exc}") from None
        return layout, ReplayTransport(rec.events, end="silent", virtual=True)
    layout, path = from_match(spec["match"])
    return layout, HidapiTransport(layout.vendor_id, layout.product_id, path=path)


def descriptor_source(ref):
    """(Descriptor, title, (vendor, product) or None, name) of what `hapticgraph hid profile` is
    given: a descriptor file (raw, hex, a recording), a connected device as VENDOR:PRODUCT in hex,
    or a connected device's hidapi path. RecordingError for a bad file, MatchError for a device."""
    if os.path.exists(ref):
        data, title = read_descriptor(ref)
        ids, name = None, ""
        with open(ref, "rb") as f:
            if re.search(rb"^R:", f.read(), re.M):
                rec = load_recording(ref)
                ids, name = (rec.vendor_id, rec.product_id), rec.name
    else:
        m = re.fullmatch(r"(?:0x)?([0-9a-fA-F]{1,4}):(?:0x)?([0-9a-fA-F]{1,4})", ref)
        if m:
            found = find({"vendor": int(m.group(1), 16), "product": int(m.group(2), 16)})
            entry, data = found.info, found.descriptor.data
        else:
            entry = connected_entry(ref)
            if entry is None:
                raise MatchError(f"{ref}: neither a file nor a connected HID device (VENDOR:PRODUCT in hex, "
                                 f"or a path `hapticgraph devices` lists)")
            data = read_device_descriptor(ref)
        ids = (entry.get("vendor_id", 0), entry.get("product_id", 0))
        name = " ".join(x for x in (entry.get("manufacturer_string"), entry.get("product_string")) if x)
        title = f"{name or 'HID device'} ({ids[0]:04x}:{ids[1]:04x}) at {entry.get('path')}"
    try:
        return parse(data), title, ids, name
    except DescriptorError as exc:
        raise RecordingError(f"{ref}: {exc}") from None


__all__ = ["descriptor_source", "from_match", "from_recording", "open_source", "recording_path"]
