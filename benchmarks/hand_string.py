"""Hand-written numba loops of the model in waveguide_string.yaml (the reference the block-built
kernel is compared with in waveguide_string.py).

A real module, not exec'd code, so that numba's `cache=True` works.

Model (all lengths in samples, ring buffers of 128 and 4 samples, one shared counter t):

    r1: nut -> P, 88        r2: P -> bridge, 112
    l2: bridge -> P, 112    l1: P -> nut, 88
    bridge = gain_bridge * (0.25 x[n] + 0.5 x[n-1] + 0.25 x[n-2]),  x = r2.out
    nut    = gain_nut * l1.out
    r2.in  = r1.out + f,  l1.in = l2.out + f  (f: half-sine force pulse of 44 samples at t = 0)
    out    = (gain_mic * (r1.out + l2.out)) * cos((pan + 1) pi / 4)

`string_hand` is what one would write by hand; `string_mirror` repeats, operation for operation,
what the generated kernel computes (the delay block's interpolation terms with coefficients
1, 0, 0, the pluck's trigger test, the mic's cos/sin every sample), to tell the framework's cost
from the cost of the general-purpose blocks. `string_hand_delay_terms` and
`string_hand_retrigger` are `string_hand` plus ONE of the block arithmetic's extras each (the
delay block's `+ 0.0 * line[t - n - 1] - 0.0 * y1`; the pluck block's second window test on its
trigger state), to show what each costs. All produce the same samples as the block-built kernel,
bit for bit.
"""
import math

import numba

MASK = 127          # delay-line rings: 128 samples (the delay block rounds 88 + 2, 112 + 2 up to it)
HMASK = 3           # the low-pass's history ring: 4 samples
D1 = 88             # nut -> pickup
D2 = 112            # pickup -> bridge
WIDTH = 44          # pluck: round(0.001 s * 44100 Hz)


@numba.njit(cache=True, nogil=True)
def string_hand(n, t0, out, r1, r2, h, l2, l1, force, g_bridge, g_nut, g_mic, pan):
    """Render n samples from counter t0 into out[0:n]; the rings carry the state between calls."""
    c_left = math.cos((pan + 1.0) * (0.25 * math.pi))
    for i in range(n):
        t = t0 + i
        k = t - 0.0
        f = 0.0
        if k >= 0.0 and k < WIDTH:
            f = force * math.sin(math.pi * (k + 0.5) / WIDTH)
        a1 = r1[(t - D1) & MASK]
        a2 = r2[(t - D2) & MASK]
        lp = g_bridge * (0.25 * a2 + 0.5 * h[(t - 1) & HMASK] + 0.25 * h[(t - 2) & HMASK])
        b2 = l2[(t - D2) & MASK]
        b1 = l1[(t - D1) & MASK]
        out[i] = (g_mic * (a1 + b2)) * c_left
        r1[t & MASK] = g_nut * b1
        r2[t & MASK] = a1 + f
        h[t & HMASK] = a2
        l2[t & MASK] = lp
        l1[t & MASK] = b2 + f
    return 0


@numba.njit(cache=True, nogil=True)
def string_mirror(n, t0, out, state, r1, r2, h, l2, l1, force, g_bridge, g_nut, g_mic, pan):
    """The generated kernel's arithmetic written out by hand (state: pluck start, last; y1 of r1, r2, l2, l1)."""
    start, last, y1, y2, y3, y4 = state[0], state[1], state[2], state[3], state[4], state[5]
    coeffs = (0.25, 0.5, 0.25)
    for i in range(n):
        t = t0 + i
        # pluck
        k = t - 0.0
        if k < 0.0 or k >= WIDTH:
            k = t - start
        if k < 0.0 or k >= WIDTH:
            f = 0.0
        else:
            f = force * math.sin(math.pi * (k + 0.5) / WIDTH)
        # delays with linear-interpolation coefficients c0 = 1, c1 = 0, allpass a = 0
        a1 = 1.0 * r1[(t - D1) & MASK] + 0.0 * r1[(t - D1 - 1) & MASK] - 0.0 * y1
        a2 = 1.0 * r2[(t - D2) & MASK] + 0.0 * r2[(t - D2 - 1) & MASK] - 0.0 * y2
        acc = coeffs[0] * a2
        for j in range(1, len(coeffs)):
            acc += coeffs[j] * h[(t - j) & HMASK]
        lp = g_bridge * acc
        b2 = 1.0 * l2[(t - D2) & MASK] + 0.0 * l2[(t - D2 - 1) & MASK] - 0.0 * y3
        b1 = 1.0 * l1[(t - D1) & MASK] + 0.0 * l1[(t - D1 - 1) & MASK] - 0.0 * y4
        nut = g_nut * b1
        theta = (pan + 1.0) * (0.25 * math.pi)
        g = g_mic * (a1 + b2)
        left, right = g * math.cos(theta), g * math.sin(theta)
        out[i] = left
        if 0.0 > 0.5 and last <= 0.5:
            start = t + 1.0
        last = 0.0
        r1[t & MASK] = nut
        y1 = a1
        r2[t & MASK] = a1 + f
        y2 = a2
        h[t & HMASK] = a2
        l2[t & MASK] = lp
        y3 = b2
        l1[t & MASK] = b2 + f
        y4 = b1
    state[0], state[1], state[2], state[3], state[4], state[5] = start, last, y1, y2, y3, y4
    return 0


@numba.njit(cache=True, nogil=True)
def string_hand_delay_terms(n, t0, out, r1, r2, h, l2, l1, force, g_bridge, g_nut, g_mic, pan):
    """string_hand with the delay block's general linear/allpass formula (c0 = 1, c1 = 0, a = 0)."""
    c_left = math.cos((pan + 1.0) * (0.25 * math.pi))
    y1 = y2 = y3 = y4 = 0.0
    for i in range(n):
        t = t0 + i
        k = t - 0.0
        f = 0.0
        if k >= 0.0 and k < WIDTH:
            f = force * math.sin(math.pi * (k + 0.5) / WIDTH)
        a1 = 1.0 * r1[(t - D1) & MASK] + 0.0 * r1[(t - D1 - 1) & MASK] - 0.0 * y1
        a2 = 1.0 * r2[(t - D2) & MASK] + 0.0 * r2[(t - D2 - 1) & MASK] - 0.0 * y2
        lp = g_bridge * (0.25 * a2 + 0.5 * h[(t - 1) & HMASK] + 0.25 * h[(t - 2) & HMASK])
        b2 = 1.0 * l2[(t - D2) & MASK] + 0.0 * l2[(t - D2 - 1) & MASK] - 0.0 * y3
        b1 = 1.0 * l1[(t - D1) & MASK] + 0.0 * l1[(t - D1 - 1) & MASK] - 0.0 * y4
        out[i] = (g_mic * (a1 + b2)) * c_left
        r1[t & MASK] = g_nut * b1
        r2[t & MASK] = a1 + f
        h[t & HMASK] = a2
        l2[t & MASK] = lp
        l1[t & MASK] = b2 + f
        y1, y2, y3, y4 = a1, a2, b2, b1
    return 0


@numba.njit(cache=True, nogil=True)
def string_hand_retrigger(n, t0, out, start, r1, r2, h, l2, l1, force, g_bridge, g_nut, g_mic, pan):
    """string_hand with the pluck block's second window test on its trigger state `start`."""
    c_left = math.cos((pan + 1.0) * (0.25 * math.pi))
    for i in range(n):
        t = t0 + i
        k = t - 0.0
        if k < 0.0 or k >= WIDTH:
            k = t - start
        f = 0.0
        if k >= 0.0 and k < WIDTH:
            f = force * math.sin(math.pi * (k + 0.5) / WIDTH)
        a1 = r1[(t - D1) & MASK]
        a2 = r2[(t - D2) & MASK]
        lp = g_bridge * (0.25 * a2 + 0.5 * h[(t - 1) & HMASK] + 0.25 * h[(t - 2) & HMASK])
        b2 = l2[(t - D2) & MASK]
        b1 = l1[(t - D1) & MASK]
        out[i] = (g_mic * (a1 + b2)) * c_left
        r1[t & MASK] = g_nut * b1
        r2[t & MASK] = a1 + f
        h[t & HMASK] = a2
        l2[t & MASK] = lp
        l1[t & MASK] = b2 + f
    return 0
