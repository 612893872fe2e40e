/* Reference for the lattice rows of benchmarks/run_all.py and benchmarks/scale.py: a uniform
   mass-spring lattice (1-D, 2-D or 3-D, fixed boundary) written the way a DSP engineer writes a
   wave-equation FDTD for its own sake: the two-level leapfrog on displacements,

       u[n+1] = A·u[n] − B·u[n−1] + C·Σ_neighbours u[n] + G·F[n]·δ(exc),

   one pass over the cells per sample, the new values written over u[n−1] and the two buffers
   swapped, ghost cells (always 0) around the grid for the fixed boundary, no force array.
   With w = dt/m:  A = 2 − w·γ − 2·D·C,  B = 1 − w·γ,  C = dt²·T/m,  G = dt²/m  (D dimensions).
   This is hapticgraph's half-step scheme (v[n+½] = v[n−½] + w·(T·Σ(x_j − x_i) + F − γ·v[n−½]),
   x[n+1] = x[n] + dt·v[n+½]) with dt·v[n−½] = x[n] − x[n−1] eliminated: the same numbers up to
   rounding. F is the `pluck` block: force·sin(π(k + ½)/width) for k = t − at in [0, width).
   out[t] = u[n][mic] (the cell's position before the step), written as a 32-bit float WAV.

   usage: ref_lattice N0[xN1[xN2]] MASS TENSION DAMPING RATE SAMPLES EXC MIC AT WIDTH FORCE OUT.wav [DUMP.f64]
   EXC and MIC are row-major cell indices; DUMP gets the output as doubles. It prints
   `loop_seconds` (the sample loop alone, output buffer prefaulted, CLOCK_MONOTONIC) and, on
   Linux, `peak_rss_kib` (VmHWM: the process's peak resident set).
   Build: gcc -O3 -march=native ref_lattice.c -o ref_lattice -lm */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int write_wav(const char *path, const double *x, int64_t n, int rate)
{
    FILE *fp = fopen(path, "wb");
    if (!fp)
        return -1;
    float *buf = malloc(n * sizeof(float));
    for (int64_t i = 0; i < n; i++)
        buf[i] = (float)x[i];
    const uint32_t data = (uint32_t)(n * 4), riff = 36 + data, fmt_size = 16, byte_rate = rate * 4;
    const uint16_t format = 3, channels = 1, align = 4, bits = 32;
    const uint32_t srate = rate;
    fwrite("RIFF", 1, 4, fp); fwrite(&riff, 4, 1, fp); fwrite("WAVEfmt ", 1, 8, fp);
    fwrite(&fmt_size, 4, 1, fp); fwrite(&format, 2, 1, fp); fwrite(&channels, 2, 1, fp);
    fwrite(&srate, 4, 1, fp); fwrite(&byte_rate, 4, 1, fp); fwrite(&align, 2, 1, fp);
    fwrite(&bits, 2, 1, fp); fwrite("data", 1, 4, fp); fwrite(&data, 4, 1, fp);
    const size_t ok = fwrite(buf, sizeof(float), n, fp);
    free(buf);
    return (fclose(fp) == 0 && ok == (size_t)n) ? 0 : -1;
}

static inline double pluck(int64_t t, double at, double width, double force)
{
    const double k = (double)t - at;
    return (k < 0.0 || k >= width) ? 0.0 : force * sin(M_PI * (k + 0.5) / width);
}

int main(int argc, char **argv)
{
    if (argc != 13 && argc != 14) {
        fprintf(stderr, "usage: %s N0[xN1[xN2]] MASS TENSION DAMPING RATE SAMPLES EXC MIC AT WIDTH FORCE OUT.wav [DUMP.f64]\n", argv[0]);
        return 2;
    }
    int64_t shape[3] = {1, 1, 1};
    int dims = sscanf(argv[1], "%ldx%ldx%ld", &shape[0], &shape[1], &shape[2]);
    const double mass = atof(argv[2]), tension = atof(argv[3]), damping = atof(argv[4]);
    const int rate = atoi(argv[5]);
    const int64_t ns = atoll(argv[6]), exc = atoll(argv[7]), mic = atoll(argv[8]);
    const double at = atof(argv[9]), width = atof(argv[10]), force = atof(argv[11]);
    if (dims < 1) { fprintf(stderr, "bad shape %s\n", argv[1]); return 2; }
    /* pad every axis with one ghost cell each side; a 1-D string is 1 x 1 x n, a sheet 1 x r x c */
    int64_t n[3] = {1, 1, 1};
    for (int d = 0; d < dims; d++) n[3 - dims + d] = shape[d];
    const int64_t p0 = dims >= 3 ? n[0] + 2 : 1, p1 = dims >= 2 ? n[1] + 2 : 1, p2 = n[2] + 2;
    const int64_t s1 = p2, s0 = p1 * p2, cells = p0 * p1 * p2;
    const int64_t o0 = dims >= 3, o1 = dims >= 2;       /* offset of the first real cell per axis */
    #define PADDED(flat) ((((flat) / (n[1] * n[2])) + o0) * s0 + ((((flat) / n[2]) % n[1]) + o1) * s1 + ((flat) % n[2]) + 1)
    const int64_t e = PADDED(exc), m = PADDED(mic);
    double *u = calloc(cells, sizeof(double)), *up = calloc(cells, sizeof(double));
    double *out = malloc(ns * sizeof(double));
    if (!u || !up || !out) { fprintf(stderr, "out of memory\n"); return 1; }
    memset(out, 0, ns * sizeof(double));                /* prefault */

    const double dt = 1.0 / rate, w = dt / mass;
    const double C = dt * dt * tension / mass, B = 1.0 - w * damping, A = 2.0 - w * damping - 2.0 * dims * C;
    const double G = dt * dt / mass;
    const double t0 = now();
    for (int64_t t = 0; t < ns; t++) {
        out[t] = u[m];
        for (int64_t a = o0; a < o0 + n[0]; a++)
            for (int64_t b = o1; b < o1 + n[1]; b++) {
                const int64_t row = a * s0 + b * s1;
                const double *restrict uu = u + row;
                double *restrict uo = up + row;
                if (dims == 1)
                    for (int64_t c = 1; c <= n[2]; c++)
                        uo[c] = A * uu[c] - B * uo[c] + C * (uu[c - 1] + uu[c + 1]);
                else if (dims == 2)
                    for (int64_t c = 1; c <= n[2]; c++)
                        uo[c] = A * uu[c] - B * uo[c] + C * (uu[c - s1] + uu[c + s1] + uu[c - 1] + uu[c + 1]);
                else
                    for (int64_t c = 1; c <= n[2]; c++)
                        uo[c] = A * uu[c] - B * uo[c]
                              + C * (uu[c - s0] + uu[c + s0] + uu[c - s1] + uu[c + s1] + uu[c - 1] + uu[c + 1]);
            }
        up[e] += G * pluck(t, at, width, force);
        double *swap = u; u = up; up = swap;
    }
    const double loop = now() - t0;
    if (write_wav(argv[12], out, ns, rate) != 0) { fprintf(stderr, "cannot write %s\n", argv[12]); return 1; }
    if (argc == 14) {
        FILE *fp = fopen(argv[13], "wb");
        if (!fp || fwrite(out, sizeof(double), ns, fp) != (size_t)ns) return 1;
        fclose(fp);
    }
    printf("loop_seconds %.9f\n", loop);
    FILE *status = fopen("/proc/self/status", "r");      /* peak resident set, for scale.py */
    char line[256];
    while (status && fgets(line, sizeof line, status))
        if (!strncmp(line, "VmHWM:", 6))
            printf("peak_rss_kib %ld\n", atol(line + 6));
    if (status)
        fclose(status);
    return 0;
}
