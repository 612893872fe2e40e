"""The C runtime every export starts with: the array views the translated functions take, and
the few operations C spells otherwise than Python (floored `//` and `%`, wraparound indices,
`min`/`max` keeping the first on a tie, a ring's power-of-two capacity), and the processor's
flush-to-zero mode around the sample loop, set where the exporting kernel sets it
(graph/fpenv.py: the SSE control register's FTZ and DAZ bits; nothing elsewhere)."""
from ..denormals import FLUSH_BITS

PRELUDE = r"""#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#ifndef HG_NO_STDIO
#include <stdio.h>
#endif
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__) && !defined(HG_NO_FLUSH)
#include <xmmintrin.h>
#endif

typedef struct { double *p; long long n; } hg_arr;
typedef struct { double *p; long long n; long long m; } hg_arr2;
typedef struct { long long *p; long long n; } hg_iarr;
typedef struct { int32_t *p; long long n; } hg_i32arr;
typedef struct { uint32_t *p; long long n; } hg_u32arr;
typedef struct { double *const *col; long long n; long long m; } hg_rec;
typedef struct { const double *const *col; long long n; long long m; } hg_ext;
typedef unsigned int hg_fpenv;

static hg_arr hg_view(double *p, long long n) { hg_arr a; a.p = p; a.n = n; return a; }
static hg_arr2 hg_view2(double *p, long long n, long long m) { hg_arr2 a; a.p = p; a.n = n; a.m = m; return a; }
static hg_iarr hg_iview(long long *p, long long n) { hg_iarr a; a.p = p; a.n = n; return a; }
static hg_i32arr hg_i32view(int32_t *p, long long n) { hg_i32arr a; a.p = p; a.n = n; return a; }
static hg_u32arr hg_u32view(uint32_t *p, long long n) { hg_u32arr a; a.p = p; a.n = n; return a; }
/* a row of a matrix, and x[lo:hi] of an array (Python's slice: from the end when negative, clipped) */
static hg_arr hg_row(hg_arr2 a, long long i) { return hg_view(a.p + i * a.m, a.m); }
static long long hg_clip(long long i, long long n) { if (i < 0) i += n; return i < 0 ? 0 : i > n ? n : i; }
static hg_arr hg_slice(hg_arr a, long long lo, long long hi)
{
    lo = hg_clip(lo, a.n);
    hi = hg_clip(hi, a.n);
    return hg_view(a.p + lo, hi > lo ? hi - lo : 0);
}
static long long hg_wrap(long long i, long long n) { return i < 0 ? i + n : i; }
static double hg_min(double a, double b) { return b < a ? b : a; }
static double hg_max(double a, double b) { return b > a ? b : a; }
static long long hg_min_i(long long a, long long b) { return b < a ? b : a; }
static long long hg_max_i(long long a, long long b) { return b > a ? b : a; }

/* Python's float %: the sign of the divisor (CPython's float_rem) */
static double hg_mod(double a, double b)
{
    double m = fmod(a, b);
    if (m != 0.0) {
        if ((b < 0.0) != (m < 0.0)) m += b;
    } else {
        m = copysign(0.0, b);
    }
    return m;
}

/* Python's float //: CPython's float_floor_div */
static double hg_floordiv(double a, double b)
{
    double m = fmod(a, b), d = (a - m) / b, f;
    if (m != 0.0 && (b < 0.0) != (m < 0.0)) d -= 1.0;
    if (d != 0.0) {
        f = floor(d);
        if (d - f > 0.5) f += 1.0;
    } else {
        f = copysign(0.0, a / b);
    }
    return f;
}

static long long hg_floordiv_i(long long a, long long b)
{
    long long q = a / b;
    if (a % b != 0 && ((a < 0) != (b < 0))) q -= 1;
    return q;
}

static long long hg_mod_i(long long a, long long b)
{
    long long r = a % b;
    if (r != 0 && ((r < 0) != (b < 0))) r += b;
    return r;
}

/* a ring buffer's length: the size rounded up to a power of two (hapticgraph.blocks.Buffer) */
static long long hg_capacity(long long n)
{
    long long c = 1;
    if (n < 1) n = 1;
    while (c < n) c <<= 1;
    return c;
}

/* why a rate is refused: problems written one a line into p (size bytes, NUL-ended, cut short);
   hg_format is snprintf. With HG_NO_STDIO (a WebAssembly module, which imports nothing) nothing is
   written: the refusal stands, unexplained. */
typedef struct { char *p; int size; int used; } hg_why;
static void hg_format(char *p, int size, const char *format, ...)
{
    va_list ap;
    if (size <= 0) return;
    p[0] = 0;
    va_start(ap, format);
#ifndef HG_NO_STDIO
    vsnprintf(p, (size_t)size, format, ap);
#endif
    va_end(ap);
}
static void hg_say(hg_why *w, const char *format, ...)
{
    va_list ap;
    int room, k = 0;
    if (w == NULL || w->p == NULL || w->size <= 1 || w->used >= w->size - 1) return;
    if (w->used > 0) { w->p[w->used++] = '\n'; w->p[w->used] = 0; }
    room = w->size - w->used;
    va_start(ap, format);
#ifndef HG_NO_STDIO
    k = vsnprintf(w->p + w->used, (size_t)room, format, ap);
#endif
    va_end(ap);
    if (k > 0) w->used += k < room ? k : room - 1;
}

#if defined(__SSE2__) && !defined(HG_NO_FLUSH)
static hg_fpenv hg_flush_enter(void) { hg_fpenv saved = _mm_getcsr(); _mm_setcsr(saved | FLUSH_BITSu); return saved; }
static void hg_flush_exit(hg_fpenv saved) { _mm_setcsr(saved); }
#else
static hg_fpenv hg_flush_enter(void) { return 0; }
static void hg_flush_exit(hg_fpenv saved) { (void)saved; }
#endif
""".replace("FLUSH_BITS", hex(FLUSH_BITS)).replace("\nstatic ", "\nstatic inline ")

__all__ = ["PRELUDE"]
