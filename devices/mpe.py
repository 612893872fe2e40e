"""MPE zones (MIDI Polyphonic Expression, MIDI Association RP-053 v1.0) for `midi_note` voices
with `mpe: lower|upper|auto`: which channel belongs to which zone, each zone's pitch bend ranges,
and each channel's bend, pressure and slide. The voice allocator (hapticgraph.devices.voices)
asks it what a note sounds.

A zone is a master channel and member channels: the lower zone master channel 1 (index 0) and
members 2 … N+1, the upper zone master 16 (index 15) and members 15 … 16−N. The MPE Configuration
Message — RPN 6 (CC 101 = 0, CC 100 = 6, CC 6 = N) on a master channel — sets N (0: the zone is
off) and the zone's ranges back to their defaults: ±48 semitones for the members, ±2 for the
master. The zone configured last keeps its channels: the other one shrinks (both together have
at most 14 members). RPN 0 (CC 6 semitones, CC 38 cents) on a master channel sets the master's
range, on a member channel every member's. Before any configuration message the played zone has
15 members (`auto`: the lower zone).
"""

LOWER, UPPER = 0, 1
MASTERS = (0, 15)                          # the master channel of each zone (MIDI channels 1 and 16)
PLAYED = {"lower": (LOWER,), "upper": (UPPER,), "auto": (LOWER, UPPER)}
MEMBER_RANGE, MASTER_RANGE = 48.0, 2.0     # semitones at full bend, the specification's defaults
MIDDLE = 64 / 127                          # CC 74's middle: a channel's slide until one is received
RPN_MSB, RPN_LSB, NRPN_MSB, NRPN_LSB, DATA_MSB, DATA_LSB = 101, 100, 99, 98, 6, 38
RPN_CONTROLS = frozenset((RPN_MSB, RPN_LSB, NRPN_MSB, NRPN_LSB, DATA_MSB, DATA_LSB))
BEND_RANGE, CONFIGURATION = (0, 0), (0, 6)


class Zones:
    """The zones of one MPE group of voices (`mode`: lower, upper or auto) and its channels' values."""

    def __init__(self, mode):
        self.mode, self.played = mode, PLAYED[mode]
        self.reset()

    def reset(self):
        self.members = [0, 0]
        self.members[UPPER if self.mode == "upper" else LOWER] = 15
        self.member_range, self.master_range = [MEMBER_RANGE] * 2, [MASTER_RANGE] * 2
        self.rpn = [None] * 16                       # the registered parameter each channel selected
        self.bend, self.pressure, self.slide = [0.0] * 16, [0.0] * 16, [MIDDLE] * 16
        self.zone = self._layout()

    def _layout(self):
        """The zone of each channel (None: no zone)."""
        zone = [None] * 16
        if self.members[LOWER]:
            for c in range(self.members[LOWER] + 1):
                zone[c] = LOWER
        if self.members[UPPER]:
            for c in range(15 - self.members[UPPER], 16):
                zone[c] = UPPER
        return zone

    # -- what a channel is -----------------------------------------------------------------------
    def zone_of(self, channel):
        """The played zone `channel` belongs to, else None (its messages are not this group's)."""
        z = self.zone[channel]
        return z if z in self.played else None

    def is_master(self, channel):
        return channel in MASTERS and self.zone[channel] is not None and MASTERS[self.zone[channel]] == channel

    def channels(self, z):
        return [c for c in range(16) if self.zone[c] == z]

    def own(self, channel):
        """A note's own bend in semitones: its member channel's bend times the members' range
        (a note on the master channel has none)."""
        return 0.0 if self.is_master(channel) else self.bend[channel] * self.member_range[self.zone[channel]]

    def common(self, z):
        """What the master channel of zone z adds to each of its notes, in semitones."""
        return self.bend[MASTERS[z]] * self.master_range[z]

    def clear(self, channel):
        """A member channel's last note ended: its next note starts from the middle."""
        self.bend[channel], self.pressure[channel], self.slide[channel] = 0.0, 0.0, MIDDLE

    # -- registered parameters -------------------------------------------------------------------
    def configure(self, m):
        """Apply a control change of RPN selection or data entry (`m.control` in RPN_CONTROLS):
        (the channels whose zone changed: their notes end, whether a bend range changed)."""
        c, number, value = m.channel, m.control, m.value
        if number in (NRPN_MSB, NRPN_LSB):
            self.rpn[c] = None
        elif number == RPN_MSB:
            self.rpn[c] = (value, self.rpn[c][1] if self.rpn[c] else None)
        elif number == RPN_LSB:
            self.rpn[c] = (self.rpn[c][0] if self.rpn[c] else None, value)
        elif self.rpn[c] == CONFIGURATION and number == DATA_MSB and c in MASTERS:
            return self._configure_zone(MASTERS.index(c), value), True
        elif self.rpn[c] == BEND_RANGE and self.zone[c] is not None:
            self._bend_range(c, number, value)
            return (), True
        return (), False

    def _bend_range(self, c, number, value):
        z = self.zone[c]
        ranges = self.master_range if self.is_master(c) else self.member_range
        semitones = float(value) if number == DATA_MSB else float(int(ranges[z]))
        cents = 0.0 if number == DATA_MSB else value / 100.0
        ranges[z] = semitones + cents

    def _configure_zone(self, z, count):
        before = list(self.zone)
        self.members[z] = min(count, 15)
        other = 1 - z
        if self.members[z] and self.members[z] + self.members[other] >= 15:
            self.members[other] = max(0, 14 - self.members[z])
        self.member_range[z], self.master_range[z] = MEMBER_RANGE, MASTER_RANGE
        self.zone = self._layout()
        moved = tuple(c for c in range(16) if self.zone[c] != before[c])
        for c in moved:
            self.clear(c)
        return moved


__all__ = ["LOWER", "MASTERS", "MASTER_RANGE", "MEMBER_RANGE", "MIDDLE", "PLAYED", "RPN_CONTROLS", "UPPER", "Zones"]
