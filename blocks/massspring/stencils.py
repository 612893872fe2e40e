"""The stencils of a uniform lattice (no locks, cuts, overrides or joins): `string_step`,
`sheet_step` and `cube_step` step a 1-D, 2-D or 3-D lattice with the same half-step arithmetic as
`network_step` (steps.py), without its CSR lists: so a 100,000-cell instrument is one loop.
"""
from ..vocabulary import helper


@helper
def string_step(pos, vel, frc, drv, inv_mass, tension, damping, dt, fixed):
    """The 1-D stencil of a uniform lattice (no locks, cuts, overrides or joins).

    Forces wired into cells are added into frc at the points drv (sorted) before the step. The
    bulk loop never touches frc: a driven interior cell's new velocity (with its force) is
    computed first into frc, the bulk loop then runs over every cell, and the driven cells take
    their velocity back from frc (which is cleared). The ends read frc anyway.
    """
    n = pos.shape[0]
    w = dt * inv_mass
    end = tension if fixed else 0.0
    if n == 1:
        vel[0] += w * (frc[0] - 2.0 * end * pos[0] - damping * vel[0])
        frc[0] = 0.0
    else:
        for k in range(drv.shape[0]):
            i = drv[k]
            if 0 < i < n - 1:
                frc[i] = vel[i] + w * (tension * (pos[i - 1] - 2.0 * pos[i] + pos[i + 1]) + frc[i] - damping * vel[i])
        vel[0] += w * (tension * (pos[1] - pos[0]) - end * pos[0] + frc[0] - damping * vel[0])
        frc[0] = 0.0
        for i in range(1, n - 1):
            vel[i] += w * (tension * (pos[i - 1] - 2.0 * pos[i] + pos[i + 1]) - damping * vel[i])
        vel[n - 1] += w * (tension * (pos[n - 2] - pos[n - 1]) - end * pos[n - 1] + frc[n - 1]
                           - damping * vel[n - 1])
        frc[n - 1] = 0.0
        for k in range(drv.shape[0]):
            i = drv[k]
            if 0 < i < n - 1:
                vel[i] = frc[i]
                frc[i] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]


@helper
def _pull(f, pos, i, step, lower, upper, fixed, xi):
    """f plus the pull on cell i (position xi) of its two neighbours `step` apart along one axis;
    a missing one (not `lower` / not `upper`) is the fixed boundary's ghost at 0, or nothing."""
    if lower:
        f += pos[i - step] - xi
    elif fixed:
        f -= xi
    if upper:
        f += pos[i + step] - xi
    elif fixed:
        f -= xi
    return f


@helper
def _sheet_velocity(pos, vel, frc, r, c, rows, cols, w, tension, damping, fixed):
    """A cell's next velocity, its force included, with every boundary test (the edges)."""
    i = r * cols + c
    xi = pos[i]
    f = _pull(0.0, pos, i, cols, r > 0, r < rows - 1, fixed, xi)
    f = _pull(f, pos, i, 1, c > 0, c < cols - 1, fixed, xi)
    return vel[i] + w * (tension * f + frc[i] - damping * vel[i])


@helper
def _sheet_aside(pos, vel, frc, drv, rows, cols, w, tension, damping, fixed, before):
    """The cells of the interior rows that the bulk loop must not decide: the first and last
    column, and the driven cells. `before` the bulk loop: each one's next velocity (its force
    included) into frc; after it: back into vel, frc cleared."""
    k = 4.0 if fixed else 3.0                                # springs pulling a side cell back
    for r in range(1, rows - 1):
        i = r * cols                                         # column 0
        j = i + cols - 1                                     # column cols - 1 (i itself when cols = 1)
        if not before:
            vel[i] = frc[i]
            vel[j] = frc[j]
            frc[i] = frc[j] = 0.0
        elif cols == 1:
            frc[i] = _sheet_velocity(pos, vel, frc, r, 0, rows, cols, w, tension, damping, fixed)
        else:
            f = (pos[i - cols] + pos[i + cols]) + pos[i + 1] - k * pos[i]
            frc[i] = vel[i] + w * (tension * f + frc[i] - damping * vel[i])
            f = (pos[j - cols] + pos[j + cols]) + pos[j - 1] - k * pos[j]
            frc[j] = vel[j] + w * (tension * f + frc[j] - damping * vel[j])
    for k in range(drv.shape[0]):
        i = drv[k]
        r, c = i // cols, i % cols
        if r < 1 or r > rows - 2 or c < 1 or c > cols - 2:
            continue                       # an edge cell: done above, or read by the edge rows
        if before:
            f = (pos[i - cols] + pos[i + cols]) + (pos[i - 1] + pos[i + 1]) - 4.0 * pos[i]
            frc[i] = vel[i] + w * (tension * f + frc[i] - damping * vel[i])
        else:
            vel[i] = frc[i]
            frc[i] = 0.0


@helper
def _sheet_bulk(up, mid, down, v, w, tension, damping):
    """Every interior row at once as one run (the views start one row apart; indexed from 1, so
    no index can be negative and there is no wraparound test per access): no tests, vectorised.
    The first and last columns come out wrong here and are set aside before, restored after.
    Σ neighbours − 4·x (rather than Σ (neighbour − x)): three fewer operations a cell, 1.4× faster."""
    for j in range(1, mid.shape[0] - 1):
        f = (up[j] + down[j]) + (mid[j - 1] + mid[j + 1]) - 4.0 * mid[j]
        v[j] += w * (tension * f - damping * v[j])


@helper
def _cube_velocity(pos, vel, frc, a, b, c, planes, rows, cols, w, tension, damping, fixed):
    """A cell's next velocity in a planes × rows × cols lattice, its force included, with every
    boundary test (the faces)."""
    s0 = rows * cols
    i = a * s0 + b * cols + c
    xi = pos[i]
    f = _pull(0.0, pos, i, s0, a > 0, a < planes - 1, fixed, xi)
    f = _pull(f, pos, i, cols, b > 0, b < rows - 1, fixed, xi)
    f = _pull(f, pos, i, 1, c > 0, c < cols - 1, fixed, xi)
    return vel[i] + w * (tension * f + frc[i] - damping * vel[i])


@helper
def _cube_aside(pos, vel, frc, drv, planes, rows, cols, w, tension, damping, fixed, before):
    """The cells of the interior rows of the interior planes that the bulk loop must not decide:
    their first and last column, and the driven cells. `before` the bulk loop: each one's next
    velocity (its force included) into frc; after it: back into vel, frc cleared."""
    for a in range(1, planes - 1):
        for b in range(1, rows - 1):
            i = (a * rows + b) * cols                        # column 0
            j = i + cols - 1                                 # column cols - 1 (i itself when cols = 1)
            if before:
                frc[i] = _cube_velocity(pos, vel, frc, a, b, 0, planes, rows, cols, w, tension, damping, fixed)
                if j != i:
                    frc[j] = _cube_velocity(pos, vel, frc, a, b, cols - 1, planes, rows, cols, w, tension, damping,
                                            fixed)
            else:
                vel[i] = frc[i]
                vel[j] = frc[j]
                frc[i] = frc[j] = 0.0
    for k in range(drv.shape[0]):
        i = drv[k]
        a, r = i // (rows * cols), i % (rows * cols)
        b, c = r // cols, r % cols
        if a < 1 or a > planes - 2 or b < 1 or b > rows - 2 or c < 1 or c > cols - 2:
            continue                       # on a face or in a set-aside column: read where it is done
        if before:
            frc[i] = _cube_velocity(pos, vel, frc, a, b, c, planes, rows, cols, w, tension, damping, fixed)
        else:
            vel[i] = frc[i]
            frc[i] = 0.0


@helper
def _cube_bulk(back, up, mid, down, front, v, w, tension, damping):
    """The interior rows of one interior plane as one run (views one plane or one row apart,
    indexed from 1: no tests, vectorised); the first and last columns come out wrong here and
    are set aside before, restored after."""
    for j in range(1, mid.shape[0] - 1):
        f = ((back[j] + front[j]) + (up[j] + down[j])) + (mid[j - 1] + mid[j + 1]) - 6.0 * mid[j]
        v[j] += w * (tension * f - damping * v[j])


@helper
def cube_step(pos, vel, frc, drv, planes, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 3-D stencil of a uniform planes × rows × cols lattice, row-major (the 7-point
    Laplacian; the CSR path took 7-10× the C FDTD's time on a cube).

    The interior rows of each interior plane are one loop with no tests (`_cube_bulk`); the cells
    it must not decide (first and last columns, driven cells at drv) are computed first into frc
    and restored after; the cells on the faces have every boundary test.
    """
    w = dt * inv_mass
    s0 = rows * cols
    n = planes * s0
    bulk = planes > 2 and rows > 2
    if bulk:
        _cube_aside(pos, vel, frc, drv, planes, rows, cols, w, tension, damping, fixed, True)
        for a in range(1, planes - 1):
            lo = a * s0 + cols                               # (a, 1, 0)
            hi = lo + (rows - 2) * cols                      # (a, rows - 1, 0), not included
            _cube_bulk(pos[lo - s0:hi - s0], pos[lo - cols:hi - cols], pos[lo:hi], pos[lo + cols:hi + cols],
                       pos[lo + s0:hi + s0], vel[lo:hi], w, tension, damping)
        _cube_aside(pos, vel, frc, drv, planes, rows, cols, w, tension, damping, fixed, False)
    for a in range(planes):
        face = not bulk or a == 0 or a == planes - 1
        for b in range(rows):
            if face or b == 0 or b == rows - 1:
                for c in range(cols):
                    i = (a * rows + b) * cols + c
                    vel[i] = _cube_velocity(pos, vel, frc, a, b, c, planes, rows, cols, w, tension, damping, fixed)
                    frc[i] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]


@helper
def sheet_step(pos, vel, frc, drv, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 2-D stencil of a uniform rows × cols lattice, row-major.

    The interior rows are one loop with no tests (`_sheet_bulk`); the cells it must not decide
    (first and last columns, driven cells at drv) are computed first into frc and restored after;
    the first and last rows have every boundary test. The bulk never reads or clears frc.
    """
    w = dt * inv_mass
    n = rows * cols
    _sheet_aside(pos, vel, frc, drv, rows, cols, w, tension, damping, fixed, True)
    if rows > 2:
        _sheet_bulk(pos[:n - 2 * cols], pos[cols:n - cols], pos[2 * cols:], vel[cols:n - cols], w, tension, damping)
    _sheet_aside(pos, vel, frc, drv, rows, cols, w, tension, damping, fixed, False)
    for r in range(0, rows, max(rows - 1, 1)):              # rows 0 and rows - 1
        for c in range(cols):
            i = r * cols + c
            vel[i] = _sheet_velocity(pos, vel, frc, r, c, rows, cols, w, tension, damping, fixed)
            frc[i] = 0.0
    for i in range(n):
        pos[i] += dt * vel[i]
