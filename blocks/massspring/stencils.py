"""The stencils of a uniform lattice (no locks, cuts, overrides or joins): `string_step`,
`sheet_step` and `cube_step` step a 1-D, 2-D or 3-D lattice in ONE pass over its cells, without
the CSR lists of `network_step` (steps.py): so a 100,000-cell instrument is one loop.

They run the half-step scheme of steps.py with the velocity eliminated, v[n−½] = (x[n] − x[n−1])/dt:

    x[n+1] = x[n] + a·(x[n] − x[n−1]) + b·(Σ_neighbours x[n] − k·x[n]) + c·F[n],
    a = 1 − dt·γ/m,   b = dt²·T/m,   c = dt²/m,

k being the cell's springs (2 per axis with a fixed boundary, whose ghost cells sit at 0; its
neighbours with a free one). The same recurrence in exact arithmetic, so the same stability bound
and the same modes; only the rounding differs from the two-pass form. It is written as increments
(x[n] − x[n−1], Σ − k·x) rather than as the FDTD's (2 − ...)·x[n] − x[n−1] + ...: that form rounds
its diagonal once and errs by the same eps·|x| every step, a drift a free lattice's rigid mode
integrates (its momentum off by 1e-9 after 0.2 s, against 1e-11 here), at the same speed. Each step writes x[n+1]
over x[n−1] (`old`) and the kernel then swaps the two buffers (the group's rotation, graph/family.py),
so the positions `x` are x[n] whenever a block reads them, and a cell's velocity
(x[n] − x[n−1])·fs is computed where it is read (a microphone, a probe, a coupling), not stored.

Each stencil runs its interior as one loop with no tests (vectorised): the cells that loop must
not decide (those at the faces of the run, and the driven cells listed in `drv`, whose force it
does not read) are computed first into `frc` and put in place after it; the faces have every
boundary test. Only the driven cells' forces are read, and each step clears them.
"""
from ..vocabulary import helper


@helper
def _coefficients(inv_mass, tension, damping, dt):
    """(a, b, c) of the one-pass recurrence at this sample's mass, tension and damping."""
    w = dt * inv_mass
    return 1.0 - w * damping, dt * w * tension, dt * w


@helper
def _side(s, k, x, i, step, lower, upper, fixed):
    """(s, k) plus cell i's two neighbours `step` apart along one axis: their positions summed
    into s, their springs counted in k; a missing one is the fixed boundary's ghost at 0 (a spring
    but nothing to add), or nothing (free)."""
    if lower:
        s += x[i - step]
        k += 1.0
    elif fixed:
        k += 1.0
    if upper:
        s += x[i + step]
        k += 1.0
    elif fixed:
        k += 1.0
    return s, k


@helper
def _next(x, old, frc, i, s, k, a, b, c):
    """Cell i's x[n+1] from its neighbours' sum s and its k springs, its force included."""
    xi = x[i]
    return xi + a * (xi - old[i]) + b * (s - k * xi) + c * frc[i]


@helper
def _line_cell(x, old, frc, i, n, a, b, c, fixed):
    s, k = _side(0.0, 0.0, x, i, 1, i > 0, i < n - 1, fixed)
    return _next(x, old, frc, i, s, k, a, b, c)


@helper
def _line_bulk(x, old, a, b):
    """Cells 1 … n−2 of a string: no tests, vectorised."""
    for i in range(1, x.shape[0] - 1):
        xi = x[i]
        old[i] = xi + a * (xi - old[i]) + b * ((x[i - 1] + x[i + 1]) - 2.0 * xi)


@helper
def string_step(x, old, frc, drv, inv_mass, tension, damping, dt, fixed):
    """The 1-D stencil: x[n+1] of every cell into `old` (then swapped with `x` by the kernel)."""
    n = x.shape[0]
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    for k in range(drv.shape[0]):                       # driven interior cells: aside, force read
        i = drv[k]
        if 0 < i < n - 1:
            xi = x[i]
            frc[i] = xi + a * (xi - old[i]) + b * ((x[i - 1] + x[i + 1]) - 2.0 * xi) + c * frc[i]
    _line_bulk(x, old, a, b)
    for k in range(drv.shape[0]):
        i = drv[k]
        if 0 < i < n - 1:
            old[i] = frc[i]
            frc[i] = 0.0
    for i in range(0, n, max(n - 1, 1)):                # the ends, with their tests
        old[i] = _line_cell(x, old, frc, i, n, a, b, c, fixed)
        frc[i] = 0.0


@helper
def _sheet_cell(x, old, frc, r, col, rows, cols, a, b, c, fixed):
    """x[n+1] of cell (r, col) of a sheet with every boundary test, its force included."""
    i = r * cols + col
    s, k = _side(0.0, 0.0, x, i, cols, r > 0, r < rows - 1, fixed)
    s, k = _side(s, k, x, i, 1, col > 0, col < cols - 1, fixed)
    return _next(x, old, frc, i, s, k, a, b, c)


@helper
def _sheet_bulk(up, mid, down, old, a, b):
    """Every interior row at once as one run (the views start one row apart and are indexed
    from 1, so no index is negative: no wraparound test per access, no tests at all: vectorised).
    The first and last columns come out wrong here: they are set aside before, put back after."""
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        old[j] = xj + a * (xj - old[j]) + b * (((up[j] + down[j]) + (mid[j - 1] + mid[j + 1])) - 4.0 * xj)


@helper
def _sheet_aside(x, old, frc, drv, rows, cols, a, b, c, fixed, before):
    """The cells of the interior rows the bulk loop must not decide: the first and last column,
    and the driven cells. `before` the bulk: each one's x[n+1] into frc; after it: into old, frc
    cleared."""
    for r in range(1, rows - 1):
        for col in range(0, cols, max(cols - 1, 1)):
            i = r * cols + col
            if before:
                frc[i] = _sheet_cell(x, old, frc, r, col, rows, cols, a, b, c, fixed)
            else:
                old[i] = frc[i]
                frc[i] = 0.0
    for k in range(drv.shape[0]):
        i = drv[k]
        r, col = i // cols, i % cols
        if r < 1 or r > rows - 2 or col < 1 or col > cols - 2:
            continue                       # an edge cell: done above, or by the edge rows
        if before:
            xi = x[i]
            s = (x[i - cols] + x[i + cols]) + (x[i - 1] + x[i + 1])
            frc[i] = xi + a * (xi - old[i]) + b * (s - 4.0 * xi) + c * frc[i]
        else:
            old[i] = frc[i]
            frc[i] = 0.0


@helper
def sheet_step(x, old, frc, drv, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 2-D stencil of a uniform rows × cols lattice, row-major: the interior rows in one run
    (`_sheet_bulk`), the cells it must not decide set aside around it, then the first and last
    rows with every boundary test. x[n+1] goes into `old`."""
    n = rows * cols
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    if rows > 2:
        _sheet_aside(x, old, frc, drv, rows, cols, a, b, c, fixed, True)
        _sheet_bulk(x[:n - 2 * cols], x[cols:n - cols], x[2 * cols:], old[cols:n - cols], a, b)
        _sheet_aside(x, old, frc, drv, rows, cols, a, b, c, fixed, False)
    for r in range(0, rows, max(rows - 1, 1)):          # rows 0 and rows - 1
        for col in range(cols):
            i = r * cols + col
            old[i] = _sheet_cell(x, old, frc, r, col, rows, cols, a, b, c, fixed)
            frc[i] = 0.0


@helper
def _cube_cell(x, old, frc, p, r, col, planes, rows, cols, a, b, c, fixed):
    """x[n+1] of cell (p, r, col) of a planes × rows × cols lattice with every boundary test."""
    s0 = rows * cols
    i = p * s0 + r * cols + col
    s, k = _side(0.0, 0.0, x, i, s0, p > 0, p < planes - 1, fixed)
    s, k = _side(s, k, x, i, cols, r > 0, r < rows - 1, fixed)
    s, k = _side(s, k, x, i, 1, col > 0, col < cols - 1, fixed)
    return _next(x, old, frc, i, s, k, a, b, c)


@helper
def _cube_bulk(back, up, mid, down, front, old, a, b):
    """The interior rows of one interior plane as one run (views one plane or one row apart,
    indexed from 1: no tests, vectorised); its first and last columns come out wrong and are set
    aside before, put back after."""
    for j in range(1, mid.shape[0] - 1):
        xj = mid[j]
        s = ((back[j] + front[j]) + (up[j] + down[j])) + (mid[j - 1] + mid[j + 1])
        old[j] = xj + a * (xj - old[j]) + b * (s - 6.0 * xj)


@helper
def _cube_aside(x, old, frc, drv, planes, rows, cols, a, b, c, fixed, before):
    """The cells of the interior rows of the interior planes the bulk loop must not decide: their
    first and last column, and the driven cells. `before`: x[n+1] into frc; after: into old."""
    for p in range(1, planes - 1):
        for r in range(1, rows - 1):
            for col in range(0, cols, max(cols - 1, 1)):
                i = (p * rows + r) * cols + col
                if before:
                    frc[i] = _cube_cell(x, old, frc, p, r, col, planes, rows, cols, a, b, c, fixed)
                else:
                    old[i] = frc[i]
                    frc[i] = 0.0
    for k in range(drv.shape[0]):
        i = drv[k]
        p, rest = i // (rows * cols), i % (rows * cols)
        r, col = rest // cols, rest % cols
        if p < 1 or p > planes - 2 or r < 1 or r > rows - 2 or col < 1 or col > cols - 2:
            continue                       # on a face or in a set-aside column: done there
        if before:
            frc[i] = _cube_cell(x, old, frc, p, r, col, planes, rows, cols, a, b, c, fixed)
        else:
            old[i] = frc[i]
            frc[i] = 0.0


@helper
def cube_step(x, old, frc, drv, planes, rows, cols, inv_mass, tension, damping, dt, fixed):
    """The 3-D stencil of a uniform planes × rows × cols lattice, row-major (the 7-point
    Laplacian): the interior rows of each interior plane in one run (`_cube_bulk`), the cells it
    must not decide set aside around it, then the faces with every boundary test."""
    a, b, c = _coefficients(inv_mass, tension, damping, dt)
    s0 = rows * cols
    bulk = planes > 2 and rows > 2
    if bulk:
        _cube_aside(x, old, frc, drv, planes, rows, cols, a, b, c, fixed, True)
        for p in range(1, planes - 1):
            lo = p * s0 + cols                               # (p, 1, 0)
            hi = lo + (rows - 2) * cols                      # (p, rows - 1, 0), not included
            _cube_bulk(x[lo - s0:hi - s0], x[lo - cols:hi - cols], x[lo:hi], x[lo + cols:hi + cols],
                       x[lo + s0:hi + s0], old[lo:hi], a, b)
        _cube_aside(x, old, frc, drv, planes, rows, cols, a, b, c, fixed, False)
    for p in range(planes):
        face = not bulk or p == 0 or p == planes - 1
        for r in range(rows):
            if face or r == 0 or r == rows - 1:
                for col in range(cols):
                    i = (p * rows + r) * cols + col
                    old[i] = _cube_cell(x, old, frc, p, r, col, planes, rows, cols, a, b, c, fixed)
                    frc[i] = 0.0
