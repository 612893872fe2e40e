"""Energy-consistent Hunt–Crossley contact: the `contact` link law and the `hammer` law
(ContactLaw, HammerLaw).

Penetration δ (δ > 0: in contact), potential V(δ) = k·δ^(α+1)/(α+1) for δ > 0, else 0, and
force F = k·δ^α + λ·δ^α·δ̇ (never negative). Both laws run after `network_step` ("post" phase,
laws.py) in the discrete-gradient form (Chatziioannou & van Walstijn 2015; Bilbao,
Numerical Sound Synthesis, ch. 4):

    F[n] = max(0, (V(δ[n+1]) − V(δ[n−1])) / (δ[n+1] − δ[n−1]) + λ·δ[n]^α·(δ[n+1] − δ[n−1])/(2·dt))

(V′ at the midpoint when δ[n+1] and δ[n−1] agree to 1e-9). With the half-step scheme's
m·(x[n+1] − 2x[n] + x[n−1])/dt² = F[n] this conserves, for λ = 0,
    H[n+½] = Σ ½·m·v[n+½]² + ½·x[n+1]ᵀ·K·x[n] + ½·(V(δ[n+1]) + V(δ[n]))
exactly (λ > 0 only removes energy). δ[n+1] depends on F: with the free positions x̃[n+1] the
step gave without the contact, δ[n+1] = δ̃ − c·F(δ[n+1]), c = dt²·(w_a + w_b) (inverse masses);
g(δ) = δ − δ̃ + c·F(δ) rises with slope ≥ 1, so its one root lies in [δ̃ − c·F(δ̃), δ̃] and a
bracketed secant (Illinois) finds it to rounding in a few iterations, only while in contact.
A contact on a point without mass (ground, a driven point) takes that point's x̃[n+1] as
x[n] + dt·v[n−½]. Contacts sharing a cell are solved one after the other (each exact for the
positions the previous ones left): energy is then conserved to the solver's residual only.
"""
from ..vocabulary import helper
from .laws import Law

TINY = 1e-9      # |δ[n+1] − δ[n−1]| below TINY·(|δ[n+1]| + |δ[n−1]|): V′ at the midpoint


@helper
def hc_potential(d, k, alpha):
    """V(δ) = k·δ^(α+1)/(α+1) for δ > 0, else 0."""
    if d <= 0.0:
        return 0.0
    return k * d ** (alpha + 1.0) / (alpha + 1.0)


@helper
def hc_gradient(d1, dm, d0, k, alpha, lam, dt):
    """F[n] for δ[n+1] = d1, δ[n−1] = dm, δ[n] = d0 (the discrete gradient and the damping)."""
    diff = d1 - dm
    if abs(diff) > TINY * (abs(d1) + abs(dm)):
        f = (hc_potential(d1, k, alpha) - hc_potential(dm, k, alpha)) / diff
    else:
        mid = 0.5 * (d1 + dm)
        f = k * mid ** alpha if mid > 0.0 else 0.0
    if d0 > 0.0:
        f += lam * d0 ** alpha * diff / (2.0 * dt)
    return f if f > 0.0 else 0.0


@helper
def hc_solve(df, dm, d0, c, k, alpha, lam, dt):
    """(δ[n+1], F) with δ[n+1] = df − c·F(δ[n+1]); see the module's docstring."""
    f = hc_gradient(df, dm, d0, k, alpha, lam, dt)
    if f == 0.0 or c == 0.0:
        return df, f
    hi, g_hi = df, c * f
    lo = df - c * f
    g_lo = lo - df + c * hc_gradient(lo, dm, d0, k, alpha, lam, dt)
    x, side = lo, 0
    for _ in range(200):
        if g_lo >= 0.0 or g_hi <= 0.0:
            x = lo if g_lo >= 0.0 else hi
            break
        x = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
        if not lo < x < hi:
            x = 0.5 * (lo + hi)
            if not lo < x < hi:
                x = lo if -g_lo < g_hi else hi
                break
        g = x - df + c * hc_gradient(x, dm, d0, k, alpha, lam, dt)
        if g > 0.0:
            hi, g_hi = x, g
            if side == 1:
                g_lo *= 0.5
            side = 1
        elif g < 0.0:
            lo, g_lo = x, g
            if side == -1:
                g_hi *= 0.5
            side = -1
        else:
            break
    return x, hc_gradient(x, dm, d0, k, alpha, lam, dt)


@helper
def inverse_mass(inv_m, scale, cid, i):
    """1/m of point i at this sample: a cell's, or 0 for an extra point."""
    if i >= cid.shape[0]:
        return 0.0
    return inv_m[i] * scale[cid[i], 0]


@helper
def free_position(pos, vel, cid, i, dt):
    """x̃[n+1] of point i after the step: a cell has moved; an extra point is extrapolated."""
    if i < cid.shape[0]:
        return pos[i]
    return pos[i] + dt * vel[i]


@helper
def push(pos, vel, frc, cid, w, i, f, dt):
    """Add force f on point i after the step (dt·w·f to v[n+½], dt²·w·f to x[n+1]); on an extra
    point, into its f (what a driven point's `force` output reads)."""
    if w != 0.0:
        vel[i] += dt * w * f
        pos[i] += dt * dt * w * f
    if i >= cid.shape[0]:
        frc[i] += f


@helper
def contact_links(pos, vel, frc, inv_m, scale, cid, ia, ib, prm, io, dt):
    """Every contact link: prm row = (gap, k, α, λ, δ[n−1], δ[n]), δ = gap − (x_b − x_a)."""
    for j in range(ia.shape[0]):
        a = ia[j]
        b = ib[j]
        wa = inverse_mass(inv_m, scale, cid, a)
        wb = inverse_mass(inv_m, scale, cid, b)
        df = prm[j, 0] - (free_position(pos, vel, cid, b, dt) - free_position(pos, vel, cid, a, dt))
        d1, f = hc_solve(df, prm[j, 4], prm[j, 5], dt * dt * (wa + wb), prm[j, 1], prm[j, 2], prm[j, 3], dt)
        push(pos, vel, frc, cid, wa, a, -f, dt)
        push(pos, vel, frc, cid, wb, b, f, dt)
        prm[j, 4] = prm[j, 5]
        prm[j, 5] = prm[j, 0] - (free_position(pos, vel, cid, b, dt) - free_position(pos, vel, cid, a, dt))
        frc[io[j]] = f


class ContactLaw(Law):
    """The unilateral Hunt–Crossley contact, energy-consistent (see the module)."""

    name = "contact"
    params = ("gap", "k", "alpha", "damping")
    phase = "post"
    links = contact_links

    @classmethod
    def pack(cls, values):
        gap = float(values["gap"])
        return [gap, float(values["k"]), float(values["alpha"]), float(values["damping"]), gap, gap]

    @classmethod
    def slope(cls, values):
        return values["k"] * values["alpha"] * values["range"] ** (values["alpha"] - 1.0)


@helper
def hammer_links(pos, vel, frc, inv_m, scale, cid, ia, ib, prm, io, dt):
    """Every hammer: ia = its own point (x, v along its direction), ib = the point it strikes.
    prm row = (0, k, α, λ, δ[n−1], δ[n], side, 1/mass, samples to the timed launch (−1: none),
    last strike input, strike input, speed input); δ = x_h − side·x_b."""
    for j in range(ia.shape[0]):
        h = ia[j]
        b = ib[j]
        s = prm[j, 6]
        wh = prm[j, 7]
        launch = prm[j, 8] == 0.0 or (prm[j, 10] > 0.5 and prm[j, 9] <= 0.5)
        if prm[j, 8] >= 0.0:
            prm[j, 8] -= 1.0
        prm[j, 9] = prm[j, 10]
        if launch:          # as if it had come at that speed: δ[n−1] = δ[n] − dt·(change of speed)
            prm[j, 4] = prm[j, 5] - dt * (prm[j, 11] - vel[h])
            vel[h] = prm[j, 11]
        yf = pos[h] + dt * vel[h]
        wb = inverse_mass(inv_m, scale, cid, b)
        df = yf - s * free_position(pos, vel, cid, b, dt)
        d1, f = hc_solve(df, prm[j, 4], prm[j, 5], dt * dt * (wh + wb), prm[j, 1], prm[j, 2], prm[j, 3], dt)
        vel[h] -= dt * wh * f
        pos[h] = yf - dt * dt * wh * f
        push(pos, vel, frc, cid, wb, b, s * f, dt)
        prm[j, 4] = prm[j, 5]
        prm[j, 5] = pos[h] - s * free_position(pos, vel, cid, b, dt)
        frc[io[j]] = f


class HammerLaw(Law):
    """A mass launched into a point through an energy-consistent Hunt–Crossley contact."""

    name = "hammer"
    params = ("k", "alpha", "damping")
    phase = "post"
    links = hammer_links
    controls = ((10, "strike"), (11, "speed"))

    @classmethod
    def row(cls, values, rate):
        launch = round(values["time"] * rate) if values["time"] >= 0 else -1.0
        side = 1.0 if values["side"] == "up" else -1.0
        return [0.0, float(values["k"]), float(values["alpha"]), float(values["damping"]), 0.0, 0.0, side,
                1.0 / values["mass"], float(launch), 0.0, 0.0, float(values["speed"])]

    @classmethod
    def slope(cls, values):
        return values["k"] * values["alpha"] * values["range"] ** (values["alpha"] - 1.0)
