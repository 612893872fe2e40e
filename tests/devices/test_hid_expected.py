"""`hapticgraph hid describe --json` against descriptors decoded by hand: beside four corpus
descriptors of different kinds (tests/data/hid) an `.expected.txt` file lists the descriptor item
by item (offset | bytes | item, read from the bytes with HID 1.11 section 6.2.2 at hand) and
then the fields that decode gives — name, kind, report id, bit offset, bit size, logical range —
and how many inputs there are. The listing is checked to be the descriptor's own bytes, in
order, so the decode cannot drift from the file; the fields are checked against our parse
(hid-tools underneath), so neither hid-tools nor our walk in test_hid_independent.py is the
only witness."""
import json
import pathlib
import re

import pytest

from hapticgraph.cli import main
from hapticgraph.devices.hid_recording import read_descriptor

DATA = pathlib.Path(__file__).resolve().parent.parent / "data" / "hid"
# file -> what makes it worth decoding by hand
DECODED = {
    "logitech_driving_force_pro_046d_c298": "a wheel: a 14-bit axis across bytes, a hat, padding, no report id",
    "saitek_joystick_pid_06a3_ff0d": "a joystick with a HID PID section: PID state inputs, signed force outputs",
    "asus_gamepad_18d1_2c40": "two top-level collections, usages out of order, 2-byte usages, LED outputs",
    "frtec_raptor_mach2_11c0_5606": "a 240-position hat, 11-bit axes, 128 buttons on 29 usages, an undefined field",
}
ITEM = re.compile(r"^# ([0-9a-f]{4}) \| ((?:[0-9a-f]{2} )+)\s*\| ")
FIELDS = ("report_id", "bit_offset", "bit_size", "logical_min", "logical_max")


def expected(stem):
    """(listing [(offset, bytes)], {(name, is_output): (kind, report_id, bit_offset, ...)}, inputs)."""
    listing, fields, inputs = [], {}, None
    for line in (DATA / f"{stem}.expected.txt").read_text(encoding="utf-8").splitlines():
        m = ITEM.match(line)
        if m:
            listing.append((int(m.group(1), 16), bytes.fromhex(m.group(2))))
        elif line.startswith("inputs "):
            inputs = int(line.split()[1])
        elif line and not line.startswith("#"):
            name, kind, *numbers = line.split()
            assert (name, kind == "output") not in fields, name
            fields[(name, kind == "output")] = (kind, *map(int, numbers))
    return listing, fields, inputs


def describe(stem, capsys):
    assert main(["hid", "describe", str(DATA / f"{stem}.rdesc"), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_every_decoded_file_is_there_and_only_those():
    assert sorted(p.name for p in DATA.glob("*.expected.txt")) == sorted(f"{s}.expected.txt" for s in DECODED)


@pytest.mark.parametrize("stem", DECODED)
def test_the_listing_is_the_descriptor_byte_for_byte(stem):
    data, _ = read_descriptor(DATA / f"{stem}.rdesc")
    listing, _, _ = expected(stem)
    at = 0
    for offset, raw in listing:
        assert offset == at, f"{stem}: an item listed at {offset:#06x}, the one before ends at {at:#06x}"
        assert data[at:at + len(raw)] == raw, f"{stem}: {raw.hex(' ')} at {at:#06x} is {data[at:at + len(raw)].hex(' ')}"
        at += len(raw)
    # whole, or (the Saitek's 625 bytes) the input reports and the first force reports
    assert at == len(data) or (stem.startswith("saitek") and at == 0x133), (stem, at)


@pytest.mark.parametrize("stem", DECODED)
def test_describe_json_gives_the_hand_decoded_fields(stem, capsys):
    items = describe(stem, capsys)
    _, fields, inputs = expected(stem)
    assert inputs == sum(1 for i in items if i["kind"] != "output")
    got = {(i["name"], i["kind"] == "output"): (i["kind"], *(i[k] for k in FIELDS)) for i in items}
    assert len(fields) >= 8
    for key, want in fields.items():
        assert got.get(key) == want, f"{stem}: {key[0]}: describe says {got.get(key)}, the decode {want}"
