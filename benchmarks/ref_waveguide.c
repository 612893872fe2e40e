/* Reference for the waveguide row of benchmarks/run_all.py: the string of
   benchmarks/waveguide_string.yaml written by hand (the loop of benchmarks/hand_string.py's
   string_hand), rendered into a buffer and written as a 32-bit float WAV.
   Four delay lines in rings of 128 samples sharing one counter, the 3-tap low-pass
   [0.25, 0.5, 0.25] with gain -0.995 at the bridge, the inverting nut, a 1 ms half-sine pluck
   entering both directions at the pickup point, the pickup reading the two arriving waves.

   usage: ref_waveguide SAMPLES OUT.wav [DUMP.f64]   (prints loop_seconds: the sample loop alone)
   Build: gcc -O3 -march=native ref_waveguide.c -o ref_waveguide -lm */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define RATE 44100
#define MASK 127
#define HMASK 3
#define D1 88
#define D2 112
#define WIDTH 44
#define FORCE 1.0
#define G_BRIDGE (-0.995)
#define G_NUT (-1.0)

static double r1[MASK + 1], r2[MASK + 1], l2[MASK + 1], l1[MASK + 1], h[HMASK + 1];

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

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 4) { fprintf(stderr, "usage: %s SAMPLES OUT.wav [DUMP.f64]\n", argv[0]); return 2; }
    const int64_t n = atoll(argv[1]);
    double *out = malloc(n * sizeof(double));
    if (!out) return 1;
    memset(out, 0, n * sizeof(double));                 /* prefault */
    const double t0 = now();
    for (int64_t t = 0; t < n; t++) {
        const double k = (double)t;
        const double f = (k < WIDTH) ? FORCE * sin(M_PI * (k + 0.5) / WIDTH) : 0.0;
        const double a1 = r1[(t - D1) & MASK];
        const double a2 = r2[(t - D2) & MASK];
        const double lp = G_BRIDGE * (0.25 * a2 + 0.5 * h[(t - 1) & HMASK] + 0.25 * h[(t - 2) & HMASK]);
        const double b2 = l2[(t - D2) & MASK];
        const double b1 = l1[(t - D1) & MASK];
        out[t] = a1 + b2;
        r1[t & MASK] = G_NUT * b1;
        r2[t & MASK] = a1 + f;
        h[t & HMASK] = a2;
        l2[t & MASK] = lp;
        l1[t & MASK] = b2 + f;
    }
    const double loop = now() - t0;
    if (write_wav(argv[2], out, n, RATE) != 0) { fprintf(stderr, "cannot write %s\n", argv[2]); return 1; }
    if (argc == 4) {
        FILE *fp = fopen(argv[3], "wb");
        if (!fp || fwrite(out, sizeof(double), n, fp) != (size_t)n) return 1;
        fclose(fp);
    }
    printf("loop_seconds %.9f\n", loop);
    return 0;
}
