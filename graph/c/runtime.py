"""The C runtime every export starts with: the array views the translated functions take, and
the few operations C spells otherwise than Python (floored `//` and `%`, wraparound indices,
`min`/`max` keeping the first on a tie, a ring's power-of-two capacity), the processor's
flush-to-zero mode around the sample loop, set where the exporting kernel sets it
(graph/fpenv.py: the SSE control register's FTZ and DAZ bits; nothing elsewhere), and the
refusals' formatting: vsnprintf, or under HG_NO_STDIO (a WebAssembly module, which imports
nothing) a formatter of its own that writes the same text (tests/export/test_wasm_refusal.py)."""
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
/* before an innermost loop of a block's or a group's function: GCC unrolls it, as clang and
   numba's LLVM do at -O3 (the same operations in the same order: the same numbers) */
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 8
#define HG_UNROLL _Pragma("GCC unroll 4")
#else
#define HG_UNROLL
#endif
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

#ifdef HG_NO_STDIO
/* vsnprintf without stdio (in a WebAssembly module wasi-libc's would import the host's files),
   for the conversions the refusals use: %s, %g with a precision, %%. %g as printf writes it: the
   value's exact decimal expansion rounded once, to nearest, ties to even. */
typedef struct { char *p; size_t size; int n; } hg_sink;
static void hg_put(hg_sink *o, char c)
{
    if ((size_t)o->n + 1 < o->size) o->p[o->n] = c;
    o->n++;
}
static void hg_puts(hg_sink *o, const char *s) { while (*s) hg_put(o, *s++); }
/* limbs (base 1e9, least significant first) times f (< 2^30) */
static void hg_times(uint32_t *limb, int *n, uint32_t f)
{
    uint64_t carry = 0, t;
    int i;
    for (i = 0; i < *n; i++) {
        t = (uint64_t)limb[i] * f + carry;
        limb[i] = (uint32_t)(t % 1000000000u);
        carry = t / 1000000000u;
    }
    for (; carry; carry /= 1000000000u) limb[(*n)++] = (uint32_t)(carry % 1000000000u);
}
/* the decimal digits of |v| (finite, not zero), all of them, into d; their count, and in *x the
   power of ten of the first: |v| = m·2^e = m·5^-e / 10^-e, an integer of at most 804 digits */
static int hg_digits(double v, char *d, int *x)
{
    uint32_t limb[96], f;
    int n = 0, e, k, j, count = 0;
    uint64_t m = (uint64_t)ldexp(frexp(fabs(v), &e), 53);
    e -= 53;
    for (; m; m /= 1000000000u) limb[n++] = (uint32_t)(m % 1000000000u);
    for (k = e; k > 0; k -= 29) hg_times(limb, &n, (uint32_t)1 << (k < 29 ? k : 29));
    for (k = -e; k > 0; k -= 12) {
        for (f = 1, j = 0; j < (k < 12 ? k : 12); j++) f *= 5;
        hg_times(limb, &n, f);
    }
    for (k = n - 1; k >= 0; k--)
        for (f = 100000000u; f; f /= 10)
            if (count || limb[k] / f % 10 || f == 1) d[count++] = (char)('0' + limb[k] / f % 10);
    *x = count - 1 + (e < 0 ? e : 0);
    return count;
}
static void hg_put_g(hg_sink *o, double v, int p)
{
    char d[832];
    int n, x, i, up;
    if (signbit(v)) hg_put(o, '-');
    if (isnan(v) || isinf(v)) { hg_puts(o, isnan(v) ? "nan" : "inf"); return; }
    if (v == 0.0) { hg_put(o, '0'); return; }
    if (p < 1) p = 1;
    n = hg_digits(v, d, &x);
    if (n > p) {
        up = d[p] > '5' || (d[p] == '5' && (d[p - 1] - '0') % 2);
        for (i = p + 1; d[p] == '5' && !up && i < n; i++) up = d[i] != '0';
        for (n = p, i = p - 1; up && i >= 0; i--) {
            up = d[i] == '9';
            d[i] = up ? '0' : (char)(d[i] + 1);
        }
        if (up) { d[0] = '1'; x++; }
    }
    while (n > 1 && d[n - 1] == '0') n--;
    if (x < -4 || x >= p) {                        /* style e */
        hg_put(o, d[0]);
        if (n > 1) hg_put(o, '.');
        for (i = 1; i < n; i++) hg_put(o, d[i]);
        hg_put(o, 'e');
        hg_put(o, x < 0 ? '-' : '+');
        if (x < 0) x = -x;
        if (x >= 100) hg_put(o, (char)('0' + x / 100));
        hg_put(o, (char)('0' + x / 10 % 10));
        hg_put(o, (char)('0' + x % 10));
    } else if (x < 0) {                            /* style f, below 1 */
        hg_puts(o, "0.");
        for (i = x + 1; i < 0; i++) hg_put(o, '0');
        for (i = 0; i < n; i++) hg_put(o, d[i]);
    } else {
        for (i = 0; i <= x; i++) hg_put(o, i < n ? d[i] : '0');
        if (n > x + 1) hg_put(o, '.');
        for (; i < n; i++) hg_put(o, d[i]);
    }
}
static int hg_vsnprintf(char *p, size_t size, const char *f, va_list ap)
{
    hg_sink o;
    int precision;
    o.p = p; o.size = size; o.n = 0;
    for (; *f; f++) {
        if (*f != '%') { hg_put(&o, *f); continue; }
        precision = 6;
        if (f[1] == '.')
            for (f++, precision = 0; f[1] >= '0' && f[1] <= '9'; f++) precision = precision * 10 + (f[1] - '0');
        if (f[1] == 0) break;
        f++;
        if (*f == 'g') hg_put_g(&o, va_arg(ap, double), precision);
        else if (*f == 's') hg_puts(&o, va_arg(ap, const char *));
        else hg_put(&o, *f);                          /* %%: the refusals use no other */
    }
    if (size > 0) p[(size_t)o.n < size ? (size_t)o.n : size - 1] = 0;
    return o.n;
}
#else
#define hg_vsnprintf vsnprintf
#endif

/* why a rate is refused: problems written one a line into p (size bytes, NUL-ended, cut short);
   hg_format is snprintf */
typedef struct { char *p; int size; int used; } hg_why;
static void hg_format(char *p, int size, const char *format, ...)
{
    va_list ap;
    if (size <= 0) return;
    p[0] = 0;
    va_start(ap, format);
    hg_vsnprintf(p, (size_t)size, format, ap);
    va_end(ap);
}
static void hg_say(hg_why *w, const char *format, ...)
{
    va_list ap;
    int room, k;
    if (w == NULL || w->p == NULL || w->size <= 1 || w->used >= w->size - 1) return;
    if (w->used > 0) { w->p[w->used++] = '\n'; w->p[w->used] = 0; }
    room = w->size - w->used;
    va_start(ap, format);
    k = hg_vsnprintf(w->p + w->used, (size_t)room, format, ap);
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
