"""The simulated haptic device, the headless default (`driver: simulated`).

The device's moving mass m is held by a hand, modelled as a spring k_h and damper R_h whose
anchor follows the scripted keyframes, and is pushed by the force the patch sends back:

    m·a = k_h·(x_hand − x) + R_h·(v_hand − v) + clip(F, ±max_force)

integrated with semi-implicit (symplectic) Euler inside the kernel, every sample, so the haptic
loop is closed in simulation with the same driver interface a real device uses. The script is
evaluated inside the kernel too (ScriptedHaptic): its keyframes reach the kernel as data
(hapticgraph.devices.script), so the driver does nothing per block but keep the force it was
sent, and another script re-uses the compiled kernel. A take records the hand's trajectory as
columns (SimulatedHaptic reads them on replay), which the driver fills only while recording.

Its `max_force` (default 4 N) is at most SIMULATED_MAX_FORCE = 50 N, the bound this model states the way a
HID profile states its device's: about what the strongest grounded desktop haptic devices give at
their peak, so a patch tuned on the simulation asks nothing absurd of a real device.
"""

import numpy as np

from ..blocks import Buffer, External, Out, Param, State, helper
from ..blocks.device import Haptic, clamp_force
from ..graph.engine import Driver
from .driver_kind import listed_axes
from .limits import SIMULATED_MAX_FORCE, force_limit
from .recordable import Recordable
from .script import script_data, script_point, script_time

# SIMULATED_MAX_FORCE (50 N, devices/limits.py): the simulated device's bound on its max_force (see
# the module's doc); limits.FORCE_CEILING (1000 N) is another thing: the most any profile or entry may state


@helper
def device_step(pos, vel, force, hand_x, hand_v, hand_stiffness, hand_damping, max_force, dt_over_m, dt):
    """One semi-implicit Euler step of the device's mass held by the hand: (pos, vel) next."""
    f = hand_stiffness * (hand_x - pos) + hand_damping * (hand_v - vel) + clamp_force(force, max_force)
    vel = vel + f * dt_over_m
    return pos + vel * dt, vel


class SimulatedHaptic(Haptic, name="simulated_haptic"):
    """m·v' = k_h(x_hand − x) + R_h(v_hand − v) + clip(F); x[n+1] = x[n] + v[n+1]/fs (semi-implicit Euler)."""

    mass = Param(0.05, unit="kg", above=0.0, live=False, internal=True)
    hand_stiffness = Param(400.0, unit="N/m", minimum=0.0, live=False, internal=True)
    hand_damping = Param(4.0, unit="N·s/m", minimum=0.0, live=False, internal=True)
    max_force = Param(4.0, unit="N", above=0.0, maximum=SIMULATED_MAX_FORCE, live=False, internal=True)
    x0 = Param(0.0, unit="m", live=False, internal=True)
    hand_x = External()
    hand_v = External()
    pos = State(lambda p, fs: p.x0)
    vel = State(0.0)

    @staticmethod
    def output(pos, vel):
        return pos, vel

    @staticmethod
    def derive(p, fs):
        # reciprocals once, so the per-sample update multiplies instead of dividing twice
        return {"dt_over_m": 1.0 / (p.mass * fs), "dt": 1.0 / fs}

    @staticmethod
    def update(pos, vel, force, hand_x, hand_v, hand_stiffness, hand_damping, max_force, dt_over_m, dt):
        return device_step(pos, vel, force, hand_x, hand_v, hand_stiffness, hand_damping, max_force, dt_over_m, dt)


class ScriptedHaptic(SimulatedHaptic, name="scripted_haptic"):
    """SimulatedHaptic whose hand follows its script inside the kernel: x_hand, v_hand = the keyframes at t/fs."""

    times = Param([0.0], unit="s", live=False, internal=True, doc="the keyframes' times")
    tracks = Param([0.0], live=False, internal=True, doc="the hand's x, then each axis, at every keyframe")
    slopes = Param([0.0], live=False, internal=True, doc="each track's slope after every keyframe")
    repeat = Param(0.0, unit="s", minimum=0.0, live=False, internal=True,
                   doc="the script's length when it repeats, 0 when its last keyframe holds")
    repeat_hi = Param(0.0, unit="s", live=False, internal=True, doc="repeat's leading 26 bits")
    repeat_lo = Param(0.0, unit="s", live=False, internal=True, doc="repeat − repeat_hi")
    # the hand this sample, for update (outputs of the model, not ports of the patch's block)
    anchor_x = Out(doc="the hand's position [m]")
    anchor_v = Out(doc="the hand's velocity [m/s]")
    anchor_key = Out(doc="the last keyframe at or before this sample's time")
    segment = State(-1.0, doc="anchor_key of the previous sample (−1: before the first keyframe)")
    axis_values = Buffer(lambda p, fs: len(p.axes), doc="this sample's value of each axis")
    # a reload that changes only the script keeps the device moving (hapticgraph.devices.watch)
    keeps_state = ("times", "tracks", "slopes", "repeat", "repeat_hi", "repeat_lo")

    @classmethod
    def ports(cls, values):
        inputs, outputs = super().ports(values)
        for k, port in enumerate(outputs[len(cls.outputs):]):
            port.element = ("axis_values", k)
        return inputs, outputs

    @staticmethod
    def derive(p, fs):
        return {"dt_over_m": 1.0 / (p.mass * fs), "dt": 1.0 / fs, "axis_count": len(p.axes)}

    @staticmethod
    def output(pos, vel, t, fs, repeat, repeat_hi, repeat_lo, times, tracks, slopes, segment, axis_count,
               axis_values):
        # the arrays are read here, not in a @helper: a call that takes an array costs two atomic
        # reference counts (Fig. 7's kernel: 34 ns a sample with such calls, 24 without; 22 with
        # the hand read from columns)
        x = script_time(t, fs, repeat, repeat_hi, repeat_lo)
        n = len(times)
        j = int(segment)                  # on from the previous sample's: a step a keyframe
        if j >= n or (j >= 0 and times[j] > x):
            j = -1                        # time went back: the script repeats
        while j + 1 < n and times[j + 1] <= x:
            j += 1
        k = min(max(j, 0), n - 1)
        inside = 0 <= j < n - 1 and times[k] != x
        for a in range(axis_count):
            at = (a + 1) * n + k
            axis_values[a] = script_point(x, times[k], tracks[at], slopes[at], inside)
        hand_x = script_point(x, times[k], tracks[k], slopes[k], inside)
        return pos, vel, hand_x, slopes[k] if j >= 0 else 0.0, float(j)

    @staticmethod
    def update(pos, vel, segment, force, anchor_x, anchor_v, anchor_key, hand_stiffness, hand_damping, max_force,
               dt_over_m, dt):
        pos, vel = device_step(pos, vel, force, anchor_x, anchor_v, hand_stiffness, hand_damping, max_force,
                               dt_over_m, dt)
        return pos, vel, anchor_key


class SimulatedDevice(Driver, Recordable):
    """Driver of one simulated device entry. Its model (ScriptedHaptic) follows the script inside
    the kernel; the driver keeps the force it was sent and, only while a take is recorded
    (`recording`), fills the hand's trajectory into its columns for the take."""

    block_type = ScriptedHaptic
    take_type = SimulatedHaptic      # what a take names: the model that reads the trajectory's columns

    def __init__(self, name, spec, axes=None):
        """`axes`: the device's axes as the patch sees them (default: from `spec`), when the
        entry was written for another driver (a HID profile's axes then come in as zeros)."""
        self.name = name
        script = spec.get("script") or [{"t": 0.0, "x": 0.0}]
        # other axes and buttons: keyframes that carry the key are interpolated, others skipped
        self.axes = list(axes) if axes is not None else listed_axes(spec)
        self.hold = bool(spec.get("hold", True))
        self.script = script_data(script, self.axes, self.hold)
        self.times = self.script["times"]
        rows = self.script["tracks"].reshape(1 + len(self.axes), len(self.times))
        self.xs, self.axis_tracks = rows[0], list(rows[1:])
        self.columns = ("hand_x", "hand_v") + tuple(self.axes)
        self.max_force = force_limit(name, "simulated", spec.get("max_force", 4.0), SIMULATED_MAX_FORCE,
                                     "the simulated device's bound")
        self.values = {"mass": float(spec.get("mass", 0.05)),
                       "hand_stiffness": float(spec.get("hand_stiffness", 400.0)),
                       "hand_damping": float(spec.get("hand_damping", 4.0)),
                       "max_force": self.max_force, "x0": float(self.xs[0])}
        self.rate = 44100.0
        self.recording = False
        self.start(self.rate)

    def block_values(self):
        return {**self.values, **self.script}

    def take_values(self):
        """The values of `take_type` a take keeps (the script is in its columns)."""
        return dict(self.values)

    def start(self, rate):
        self.rate = float(rate)
        self._ring, self._count = None, 0
        self._cache = None

    def hand(self, t):
        """Hand anchor position and velocity at times t (s): linear between keyframes.

        The velocity is each segment's slope, filled run by run (t increases within a run; a
        repeated script wraps around between runs): a few slices a chunk rather than a search,
        a gather and a division per sample."""
        return self._hand_at(self._wrapped(t))

    def _wrapped(self, t):
        """Times into the script: wrapped around its length when it repeats (hold: false)."""
        return np.mod(t, self.times[-1]) if not self.hold and self.times[-1] > 0 else t

    def _hand_at(self, t):
        times, xs = self.times, self.xs
        x = np.interp(t, times, xs)
        v = np.zeros_like(t)
        if len(times) < 2:
            return x, v
        slopes = self.script["slopes"][:len(times) - 1]     # the hand's row: each segment's slope
        cuts = np.flatnonzero(t[1:] < t[:-1]) + 1
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(t)]):
            edges = a + np.searchsorted(t[a:b], times, side="left")   # first sample at or after each keyframe
            for j in range(len(slopes)):
                v[edges[j]:edges[j + 1]] = slopes[j]
        return x, v

    WINDOW = 4096   # samples of script computed at once, so small blocks cost a copy

    def _compute(self, t0, n):
        tt = self._wrapped((t0 + np.arange(n)) / self.rate)
        out = np.empty((n, len(self.columns)))
        out[:, 0], out[:, 1] = self._hand_at(tt)
        for k, track in enumerate(self.axis_tracks):
            out[:, 2 + k] = np.interp(tt, self.times, track)
        return out

    def fill(self, t0, ext):
        if not self.recording:       # the kernel computes the hand itself; a take needs its columns
            return
        n = ext.shape[0]
        if n >= self.WINDOW:
            ext[:] = self._compute(t0, n)
            return
        cache = getattr(self, "_cache", None)
        if cache is None or not (self._cache_t0 <= t0 and t0 + n <= self._cache_t0 + len(cache)):
            self._cache, self._cache_t0 = self._compute(t0, self.WINDOW), t0
        ext[:] = self._cache[t0 - self._cache_t0: t0 - self._cache_t0 + n]

    KEEP = 1 << 22   # samples of sent force kept for inspection (about 95 s at 44.1 kHz)

    def send(self, t0, force):
        # the latest KEEP samples, as sent: one copy into a ring (its pages touched as it fills)
        n = len(force)
        if self._ring is None:
            self._ring = np.empty(self.KEEP)
        at = self._count % self.KEEP
        if n == 1:                       # a servo loop's sample: one element, no slices
            self._ring[at] = force[0]
            self._count += 1
            return
        k = min(n, self.KEEP - at)
        self._ring[at:at + k] = force[:k]
        self._ring[:n - k] = force[k:]
        self._count += n

    def force_sent(self):
        """The force the device received, sample by sample (the latest KEEP): clamped to
        ±max_force, NaN and infinities as zero, as a device's driver sends it."""
        kept = min(self._count, self.KEEP)
        if not kept:
            return np.zeros(0)
        at = self._count % self.KEEP
        sent = np.concatenate((self._ring[at:], self._ring[:at])) if self._count > self.KEEP else self._ring[:kept]
        return np.clip(np.nan_to_num(sent, nan=0.0, posinf=0.0, neginf=0.0), -self.max_force, self.max_force)
