/* A C host for the exported Fig. 8 pluck-and-damp instrument (hapticgraph export
   patches/fig8_pluck_damp.yaml --to c --name fig8): a simulated finger plucks the string and
   then rests on it to damp it, as the patch's simulated device does, and the string sounds
   through JACK (or into a file, offline).

   The haptic loop is closed every sample: the host reads the finger (here: a 50 g mass held by a
   hand that follows a script), calls fig8_process for ONE sample with the finger's position,
   velocity and grip, and applies the force it returns to the finger before the next sample. The
   exported code already clamps that force to the patch's max_force (4 N), exactly as the kernel
   does; HOST_MAX_FORCE is the host's own limit on top, the one a real device's driver keeps.

   ./host --offline SECONDS FILE   raw float64 rows (left, right, force, finger x), at the patch's rate
   ./host [--seconds S]            a JACK client "fig8" with two audio outputs, for S seconds */
#define _POSIX_C_SOURCE 200809L
#include <jack/jack.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "fig8.h"

#define HOST_MAX_FORCE 3.5            /* N: the host's limit, under the patch's 4 N */

typedef struct { double t, v; } key;
/* the patch's script: the hand's position (m) and the grip (N, the plucker's release), linear between keys */
static const key hand_x[] = {{0.0, -0.001}, {0.135, 0.02}, {0.7, 0.02}, {0.8, 0.0}};
static const key grip[] = {{0.0, 1.5}, {0.5, 1.5}, {0.55, 0.3}};

static double track(const key *k, int n, double t, double *slope)
{
    int i;
    *slope = 0.0;
    if (t < k[0].t) return k[0].v;
    for (i = 0; i + 1 < n; i++)
        if (t < k[i + 1].t) {
            *slope = (k[i + 1].v - k[i].v) / (k[i + 1].t - k[i].t);
            return k[i].v + *slope * (t - k[i].t);
        }
    return k[n - 1].v;
}

typedef struct {
    fig8 *s;
    double rate, pos, vel, max_seen;
    long long n;
} host;

/* one sample of the closed loop: the finger in, the string's sample and the force out */
static void tick(host *h, double *left, double *right)
{
    const double mass = 0.05, hand_k = 400.0, hand_r = 4.0, dt = 1.0 / h->rate;
    double t = (double)h->n * dt, hv, gv, hx = track(hand_x, 4, t, &hv), g = track(grip, 3, t, &gv);
    double x = h->pos, v = h->vel, l, r, force, f;
    const double *in[3] = {&x, &v, &g};
    double *out[3] = {&l, &r, &force};
    if (fig8_process(h->s, in, out, 1) != 0) force = 0.0;        /* a fault: the forces are zero */
    force = force > HOST_MAX_FORCE ? HOST_MAX_FORCE : force < -HOST_MAX_FORCE ? -HOST_MAX_FORCE : force;
    if (fabs(force) > h->max_seen) h->max_seen = fabs(force);
    f = hand_k * (hx - h->pos) + hand_r * (hv - h->vel) + force;  /* semi-implicit Euler, as the simulation */
    h->vel += f * dt / mass;
    h->pos += h->vel * dt;
    h->n++;
    *left = l;
    *right = r;
}

static jack_port_t *ports[2];
static volatile sig_atomic_t stop;

static int process(jack_nframes_t n, void *arg)
{
    host *h = (host *)arg;
    float *l = (float *)jack_port_get_buffer(ports[0], n), *r = (float *)jack_port_get_buffer(ports[1], n);
    jack_nframes_t i;
    double a, b;
    for (i = 0; i < n; i++) {
        tick(h, &a, &b);
        l[i] = (float)a;
        r[i] = (float)b;
    }
    return 0;
}

static void on_signal(int sig) { (void)sig; stop = 1; }

static int offline(host *h, double seconds, const char *path)
{
    FILE *f = fopen(path, "wb");
    long long i, total = (long long)(seconds * h->rate);
    double row[4];
    if (f == NULL) { perror(path); return 1; }
    for (i = 0; i < total; i++) {
        tick(h, &row[0], &row[1]);
        row[2] = h->max_seen;
        row[3] = h->pos;
        fwrite(row, sizeof row[0], 4, f);
    }
    return fclose(f) != 0;
}

static int live(host *h, double seconds)
{
    struct timespec nap = {0, 10000000};
    double waited = 0.0;
    jack_client_t *c = jack_client_open("fig8", JackNoStartServer, NULL);
    if (c == NULL) { fputs("host: no JACK server\n", stderr); return 2; }
    h->rate = jack_get_sample_rate(c);
    if ((h->s = fig8_new(h->rate)) == NULL) { fprintf(stderr, "host: fig8 refuses %g Hz\n", h->rate); return 3; }
    ports[0] = jack_port_register(c, "out_left", JACK_DEFAULT_AUDIO_TYPE, JackPortIsOutput, 0);
    ports[1] = jack_port_register(c, "out_right", JACK_DEFAULT_AUDIO_TYPE, JackPortIsOutput, 0);
    jack_set_process_callback(c, process, h);
    if (ports[0] == NULL || ports[1] == NULL || jack_activate(c) != 0) {
        fputs("host: JACK refused\n", stderr);
        return 2;
    }
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    while (!stop && (seconds <= 0.0 || waited < seconds)) {
        nanosleep(&nap, NULL);
        waited += 0.01;
    }
    jack_deactivate(c);
    jack_client_close(c);
    printf("%lld samples at %g Hz, largest force %.6f N\n", h->n, h->rate, h->max_seen);
    return 0;
}

int main(int argc, char **argv)
{
    host h;
    int code;
    memset(&h, 0, sizeof h);
    if (argc == 4 && strcmp(argv[1], "--offline") == 0) {
        h.rate = FIG8_RATE;
        h.s = fig8_new(h.rate);
        h.pos = hand_x[0].v;
        code = offline(&h, atof(argv[2]), argv[3]);
    } else {
        h.pos = hand_x[0].v;
        code = live(&h, argc == 3 && strcmp(argv[1], "--seconds") == 0 ? atof(argv[2]) : 0.0);
    }
    fig8_free(h.s);
    return code;
}
