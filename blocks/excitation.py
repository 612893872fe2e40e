"""Excitations: force pulses, oscillators and seeded noise."""
import math

from .vocabulary import Block, In, Out, Param, State, helper

_M1, _M2 = 2147483563.0, 2147483399.0


class Pluck(Block, name="pluck"):
    """out[n] = force · sin(π(k + ½)/N) for k = n − start in [0, N), N = duration·fs; start = time·fs or a rising trigger."""

    trigger = In(doc="a rising edge through 0.5 starts a pulse at the next sample")
    y = Out(name="out")
    time = Param(0.0, unit="s", minimum=-1.0, maximum=1e6, live=False,
                 doc="when the scheduled pulse starts; negative: only the trigger plucks")
    force = Param(1.0, unit="N", minimum=-1e6, maximum=1e6)
    duration = Param(0.001, unit="s", above=0.0, maximum=10.0, live=False)
    start = State(-1e18)
    last = State(0.0)

    @staticmethod
    def derive(p, fs):
        n = max(1, int(round(p.duration * fs)))
        at = float(round(p.time * fs)) if p.time >= 0.0 else -1e18
        return {"width": n, "at": at}

    @staticmethod
    def output(t, width, at, force, start):
        k = t - at
        if k < 0.0 or k >= width:
            if start < -1e17:      # never triggered: one cheap test instead of a second window
                return 0.0
            k = t - start
            if k < 0.0 or k >= width:
                return 0.0
        return force * math.sin(math.pi * (k + 0.5) / width)

    @staticmethod
    def update(t, trigger, last, start):
        if trigger > 0.5 and last <= 0.5:
            start = t + 1.0
        return start, trigger


@helper
def _polyblep(ph, dt):
    """Two-sample polynomial band-limited step residual at phase 0 (Välimäki & Huovilainen 2007)."""
    if ph < dt:
        x = ph / dt
        return x + x - x * x - 1.0
    if ph > 1.0 - dt:
        x = (ph - 1.0) / dt
        return x * x + x + x + 1.0
    return 0.0


class Wavetable(Block, name="wavetable"):
    """out[n] = amplitude · shape(φ[n]), φ[n+1] = frac(φ[n] + frequency/fs); saw and square PolyBLEP band-limited when bandlimited."""

    y = Out(name="out")
    shape = Param("sine", choices=("sine", "square", "triangle", "sawtooth"))
    frequency = Param(440.0, unit="Hz", minimum=-1e5, maximum=1e5)
    amplitude = Param(1.0, unit="N", minimum=-1e6, maximum=1e6)
    phase = Param(0.0, minimum=0.0, below=1.0, live=False, doc="initial phase, in cycles")
    bandlimited = Param(True, doc="PolyBLEP on the square and sawtooth steps; the triangle is never corrected")
    ph = State(lambda p, fs: p.phase)

    structure = ("code", "blep")       # the shape and band-limiting are choices

    @staticmethod
    def derive(p, fs):
        return {"code": ("sine", "square", "triangle", "sawtooth").index(p.shape),
                "blep": bool(p.bandlimited)}

    @staticmethod
    def output(ph, frequency, amplitude, fs, code, blep):
        dt = min(abs(frequency) / fs, 0.5)
        if code == 0:
            v = math.sin(2.0 * math.pi * ph)
        elif code == 1:
            v = 1.0 if ph < 0.5 else -1.0
            if blep and dt > 0.0:
                v += _polyblep(ph, dt) - _polyblep((ph + 0.5) % 1.0, dt)
        elif code == 2:
            v = 1.0 - 2.0 * abs(2.0 * ((ph + 0.25) % 1.0) - 1.0)
        else:
            v = 2.0 * ph - 1.0
            if blep and dt > 0.0:
                v -= _polyblep(ph, dt)
        return amplitude * v

    @staticmethod
    def update(ph, frequency, fs):
        ph += frequency / fs
        return ph - math.floor(ph)


class Noise(Block, name="noise"):
    """out[n] = amplitude · (2u[n] − 1), u uniform in (0, 1) from L'Ecuyer's combined generator, exact in float64.  Ref: L'Ecuyer 1988."""

    y = Out(name="out")
    amplitude = Param(1.0, unit="N", minimum=-1e6, maximum=1e6)
    seed = Param(1, minimum=0, maximum=2**31 - 2, doc="the same seed gives the same sequence")
    s1 = State(lambda p, fs: float(p.seed % 2147483562 + 1))
    s2 = State(lambda p, fs: float((p.seed * 7919 + 12345) % 2147483398 + 1))

    @staticmethod
    def output(s1, s2, amplitude):
        z = s1 - s2
        if z < 1.0:
            z += _M1 - 1.0
        return amplitude * (2.0 * z / _M1 - 1.0)

    @staticmethod
    def update(s1, s2):
        # products stay below 2**47, so float64 arithmetic is exact here and in the interpreter
        return (40014.0 * s1) % _M1, (40692.0 * s2) % _M2
