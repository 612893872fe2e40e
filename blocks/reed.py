"""The reed excitation (Howard & Rimell 2003, Cymatic's velocity-dependent "reed table").

A pressure-controlled valve on one cell. The mouth pressure p pushes on the cell through the
reed; the cell's own motion builds a back-pressure Z·v (Z an acoustic impedance), so the pressure
drop across the reed is Δp = p − Z·v. How far the reed is open follows STK's ReedTable, a
memoryless spring reed that saturates when it beats against the lay:

    r(Δp) = clip(offset + slope·Δp, −1, 1)          (STK ReedTable; slope < 0: it closes as Δp grows)

and the force on the cell is the pressure drop over the open area, F = area·Δp·r(Δp). The force
curve F(Δp) = area·Δp·(offset + slope·Δp) rises, peaks at Δp = −offset/(2·slope), then falls:
on that falling branch dF/dv = −area·Z·(offset + 2·slope·Δp) > 0, a negative resistance, so a
cell blown above the threshold pressure oscillates by itself (the clarinet mechanism; McIntyre,
Schumacher & Woodhouse 1983). The block reads `v` of the same sample, like `bow`: a cell's
velocity output does not feed through, so a reed on a cell makes no algebraic loop.
"""
from .vocabulary import Block, In, Out, Param


class Reed(Block, name="reed"):
    """Δp = pressure − impedance·v, force = area·Δp·clip(offset + slope·Δp, −1, 1).  Ref: STK ReedTable (Smith 1986); Howard & Rimell 2003 (reed table)."""

    pressure = In(doc="mouth (blowing) pressure [Pa]")
    v = In(doc="velocity of the cell the reed drives [m/s]")
    force = Out(doc="force on the cell [N]")
    offset = Param(0.6, minimum=-10.0, maximum=10.0, doc="reed table at Δp = 0: the rest opening")
    slope = Param(-0.0008, unit="1/Pa", minimum=-1e3, maximum=1e3,
                  doc="reed table slope (negative: the reed closes as the pressure drop grows)")
    area = Param(1e-4, unit="m²", minimum=0.0, maximum=1e3, doc="area the pressure drop acts on")
    impedance = Param(413.0, unit="Pa·s/m", minimum=0.0, maximum=1e9,
                      doc="back-pressure per unit cell velocity (413: ρc of air)")

    @staticmethod
    def output(pressure, v, offset, slope, area, impedance):
        dp = pressure - impedance * v
        r = min(max(offset + slope * dp, -1.0), 1.0)
        return area * dp * r
