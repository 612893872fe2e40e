/* The MIDI driver of an exported patch, in C: NAME_midi's events turned into the midi_note and
   midi_cc columns, as hapticgraph.devices.midi, .voices and .mpe turn a MIDI file's. A word between
   two at signs is a constant of those modules, filled in by hapticgraph.devices.midi_c at export;
   the counts of blocks (HG_N_NOTES, HG_N_CCS, HG_N_ALLOCS, HG_VOICES) are defined before. */
#define HG_QUEUE @QUEUE@
#define HG_NOTES 2048                       /* a note is channel·128 + key */
#define HG_MIDDLE (64.0 / 127.0)            /* CC 74 before one is received */
#define HG_MEMBER_RANGE @MEMBER_RANGE@
#define HG_MASTER_RANGE @MASTER_RANGE@
#define HG_SLIDE_CC @SLIDE_CC@
#define HG_IS_ALL_OFF(c) (@ALL_OFF@)
#define HG_IS_RPN(c) (@RPN@)
enum { @COLUMNS@, HG_COLUMNS };            /* a midi_note's columns, in devices/voices.py's order */
static const int hg_masters[2] = {@MASTERS@};

typedef struct { long long at; unsigned char b[3]; } hg_event;
typedef struct { unsigned char b[3]; } hg_msg;

/* what the events of one sample do (hapticgraph.devices.voices.resolve) */
typedef struct {
    hg_msg msg[HG_QUEUE * 16];              /* the sample's messages (MPE: all-notes-off spread over a zone) */
    hg_msg given[HG_QUEUE];                 /* MPE: the sample's messages as given */
    int ended[HG_NOTES], n_ended;           /* notes held before the sample that it ends, in order */
    int struck[HG_NOTES], n_struck;         /* notes struck, in the order first struck */
    int struck_msg[HG_NOTES];               /* each note's last note-on among msg, or -1 */
    unsigned char is_ended[HG_NOTES], is_short[HG_NOTES], held[HG_NOTES];
} hg_scratch;

static int hg_kind(const hg_msg *m) { return m->b[0] >> 4; }
static int hg_channel(const hg_msg *m) { return m->b[0] & 15; }
static int hg_note_on(const hg_msg *m) { return hg_kind(m) == 9 && m->b[2] > 0; }
static int hg_note_off(const hg_msg *m) { return hg_kind(m) == 8 || (hg_kind(m) == 9 && m->b[2] == 0); }
static int hg_cc(const hg_msg *m, int number) { return hg_kind(m) == 11 && m->b[1] == number; }
static int hg_bend_of(const hg_msg *m) { return ((m->b[2] << 7) | m->b[1]) - 8192; }

static void hg_end(hg_scratch *r, int channel, int key)
{
    int note = channel * 128 + key;
    if (r->held[note] && !r->is_ended[note]) { r->is_ended[note] = 1; r->ended[r->n_ended++] = note; }
    else if (r->struck_msg[note] >= 0) r->is_short[note] = 1;
}

/* the sample's n messages in r->msg; r->held: the notes sounding before it */
static void hg_resolve(hg_scratch *r, int n)
{
    int k, key;
    for (k = 0; k < n; k++) {
        const hg_msg *m = &r->msg[k];
        if (hg_note_on(m)) {
            int note = hg_channel(m) * 128 + m->b[1];
            if (r->struck_msg[note] < 0) r->struck[r->n_struck++] = note;
            r->struck_msg[note] = k;
            r->is_short[note] = 0;
        } else if (hg_note_off(m)) {
            hg_end(r, hg_channel(m), m->b[1]);
        } else if (hg_kind(m) == 11 && HG_IS_ALL_OFF(m->b[1])) {
            for (key = 0; key < 128; key++) hg_end(r, hg_channel(m), key);
        }
    }
}

static void hg_resolved(hg_scratch *r)
{
    int k;
    for (k = 0; k < r->n_ended; k++) r->is_ended[r->ended[k]] = 0;
    for (k = 0; k < r->n_struck; k++) { r->struck_msg[r->struck[k]] = -1; r->is_short[r->struck[k]] = 0; }
    r->n_ended = r->n_struck = 0;
}

/* ---- midi_note with voice 0: the newest note held (hapticgraph.devices.midi.NoteTap) */
typedef struct {
    int channel, col;                       /* channel -1: every channel; col: its first column */
    double row[HG_COLUMNS];
    int held[HG_NOTES], n_held;             /* oldest first */
    int end_note[HG_NOTES], n_ends;         /* notes struck and released at one sample ... */
    long long end_at[HG_NOTES];             /* ... and the sample they end */
    unsigned char is_held[HG_NOTES];
    double bend[16], slide[16];
    int sounding;                           /* the channel of the sounding note, -1 before any */
} hg_note_tap;

static void hg_note_reset(hg_note_tap *p)
{
    int c;
    const double row[HG_COLUMNS] = {0.0, 69.0, 0.0, 0.0, 0.0, HG_MIDDLE, 0.0};
    memcpy(p->row, row, sizeof row);
    memset(p->is_held, 0, sizeof p->is_held);
    p->n_held = p->n_ends = 0;
    for (c = 0; c < 16; c++) { p->bend[c] = 0.0; p->slide[c] = HG_MIDDLE; }
    p->sounding = -1;
}

static void hg_note_unend(hg_note_tap *p, int note)
{
    int e;
    for (e = 0; e < p->n_ends; e++)
        if (p->end_note[e] == note) { p->end_note[e] = p->end_note[p->n_ends - 1]; p->end_at[e] = p->end_at[--p->n_ends]; return; }
}

static void hg_note_drop(hg_note_tap *p, int note)
{
    int k;
    hg_note_unend(p, note);
    if (!p->is_held[note]) return;
    p->is_held[note] = 0;
    for (k = 0; p->held[k] != note; k++) ;
    for (; k + 1 < p->n_held; k++) p->held[k] = p->held[k + 1];
    p->n_held--;
}

static void hg_note_at(hg_note_tap *p, hg_scratch *r, int n, long long at)
{
    int k, e;
    for (e = 0; e < p->n_ends; )
        if (p->end_at[e] <= at) hg_note_drop(p, p->end_note[e]); else e++;
    memcpy(r->held, p->is_held, sizeof r->held);
    hg_resolve(r, n);
    for (k = 0; k < r->n_ended; k++) hg_note_drop(p, r->ended[k]);
    for (k = 0; k < r->n_struck; k++) {
        int note = r->struck[k];
        const hg_msg *m = &r->msg[r->struck_msg[note]];
        if (p->is_held[note]) hg_note_drop(p, note);
        hg_note_unend(p, note);
        p->held[p->n_held++] = note;
        p->is_held[note] = 1;
        p->row[HG_VELOCITY] = m->b[2] / 127.0;
        p->sounding = hg_channel(m);
        if (r->is_short[note]) { p->end_note[p->n_ends] = note; p->end_at[p->n_ends++] = at + 1; }
    }
    for (k = 0; k < n; k++) {
        const hg_msg *m = &r->msg[k];
        int c = hg_channel(m);
        if (hg_kind(m) == 14) p->bend[c] = hg_bend_of(m) / 8192.0;
        else if (hg_cc(m, HG_SLIDE_CC)) p->slide[c] = m->b[2] / 127.0;
        else if (hg_kind(m) == 13 && c == p->sounding) p->row[HG_PRESSURE] = m->b[1] / 127.0;
        else if (hg_kind(m) == 10 && p->n_held && c * 128 + m->b[1] == p->held[p->n_held - 1])
            p->row[HG_PRESSURE] = m->b[2] / 127.0;
    }
    memset(r->held, 0, sizeof r->held);
    hg_resolved(r);
    if (p->n_held) {
        p->sounding = p->held[p->n_held - 1] / 128;
        p->row[HG_GATE] = 1.0;
        p->row[HG_NOTE] = (double)(p->held[p->n_held - 1] % 128);
    } else {
        p->row[HG_GATE] = 0.0;
    }
    if (p->sounding >= 0) { p->row[HG_BEND] = p->bend[p->sounding]; p->row[HG_SLIDE] = p->slide[p->sounding]; }
}

/* ---- midi_cc: the value / 127 of one controller (hapticgraph.devices.midi.ControlTap) */
typedef struct { int channel, number, col; double value; } hg_cc_tap;

/* ---- MPE zones (hapticgraph.devices.mpe.Zones) */
typedef struct {
    int mode, members[2], zone[16], rpn_msb[16], rpn_lsb[16];  /* zone -1: none; rpn -1: none selected */
    double member_range[2], master_range[2], bend[16], pressure[16], slide[16];
} hg_zones;

static const unsigned char hg_plays[4][2] = {@PLAYS@};     /* [mode][zone]: the zones each mode plays */
static int hg_played(const hg_zones *z, int zone) { return zone >= 0 && hg_plays[z->mode][zone]; }
static int hg_zone_of(const hg_zones *z, int c) { return hg_played(z, z->zone[c]) ? z->zone[c] : -1; }
static int hg_is_master(const hg_zones *z, int c) { return (c == hg_masters[0] || c == hg_masters[1]) && z->zone[c] >= 0 && hg_masters[z->zone[c]] == c; }
static double hg_own(const hg_zones *z, int c) { return hg_is_master(z, c) ? 0.0 : z->bend[c] * z->member_range[z->zone[c]]; }
static double hg_common(const hg_zones *z, int zone) { return z->bend[hg_masters[zone]] * z->master_range[zone]; }
static void hg_clear(hg_zones *z, int c) { z->bend[c] = 0.0; z->pressure[c] = 0.0; z->slide[c] = HG_MIDDLE; }

static void hg_layout(hg_zones *z)
{
    int c;
    for (c = 0; c < 16; c++) z->zone[c] = -1;
    if (z->members[0]) for (c = 0; c < z->members[0] + 1; c++) z->zone[c] = 0;
    if (z->members[1]) for (c = 15 - z->members[1]; c < 16; c++) z->zone[c] = 1;
}

static void hg_zones_reset(hg_zones *z)
{
    int c;
    z->members[0] = z->members[1] = 0;
    z->members[z->mode == @UPPER_MODE@ ? @UPPER@ : @LOWER@] = 15;
    z->member_range[0] = z->member_range[1] = HG_MEMBER_RANGE;
    z->master_range[0] = z->master_range[1] = HG_MASTER_RANGE;
    for (c = 0; c < 16; c++) { z->rpn_msb[c] = z->rpn_lsb[c] = -1; z->bend[c] = z->pressure[c] = 0.0; z->slide[c] = HG_MIDDLE; }
    hg_layout(z);
}

/* an RPN selection or data entry: 1 when a bend range changed; moved[c] set for the channels
   whose zone changed */
static int hg_configure(hg_zones *z, const hg_msg *m, unsigned char *moved)
{
    int c = hg_channel(m), number = m->b[1], value = m->b[2], k;
    if (number == @NRPN_MSB@ || number == @NRPN_LSB@) { z->rpn_msb[c] = z->rpn_lsb[c] = -1; return 0; }
    if (number == @RPN_MSB@) { z->rpn_msb[c] = value; return 0; }
    if (number == @RPN_LSB@) { z->rpn_lsb[c] = value; return 0; }
    if (z->rpn_msb[c] == @CONFIGURATION_MSB@ && z->rpn_lsb[c] == @CONFIGURATION_LSB@ && number == @DATA_MSB@ && (c == hg_masters[0] || c == hg_masters[1])) {
        int zone = c == hg_masters[0] ? 0 : 1, other = 1 - zone, before[16];
        memcpy(before, z->zone, sizeof before);
        z->members[zone] = value < 15 ? value : 15;
        if (z->members[zone] && z->members[zone] + z->members[other] >= 15)
            z->members[other] = 14 - z->members[zone] > 0 ? 14 - z->members[zone] : 0;
        z->member_range[zone] = HG_MEMBER_RANGE;
        z->master_range[zone] = HG_MASTER_RANGE;
        hg_layout(z);
        for (k = 0; k < 16; k++) if (z->zone[k] != before[k]) { moved[k] = 1; hg_clear(z, k); }
        return 1;
    }
    if (z->rpn_msb[c] == @BEND_RANGE_MSB@ && z->rpn_lsb[c] == @BEND_RANGE_LSB@ && z->zone[c] >= 0) {
        double *ranges = hg_is_master(z, c) ? z->master_range : z->member_range;
        int zone = z->zone[c];
        ranges[zone] = number == @DATA_MSB@ ? (double)value : (double)(long long)ranges[zone] + value / 100.0;
        return 1;
    }
    return 0;
}

/* ---- midi_note with voice k of voices N (hapticgraph.devices.voices.Allocator) */
typedef struct {
    int channel, count;                     /* channel -1: every channel */
    int col[HG_VOICES];                     /* each voice's first column, -1: no block reads it */
    double rows[HG_VOICES][HG_COLUMNS], own[HG_VOICES];
    int zone_of[HG_VOICES], owner[HG_VOICES];   /* -1: none */
    unsigned char held[HG_VOICES];
    long long since[HG_VOICES], clock, end[HG_VOICES], end_seq[HG_VOICES], seq, done;  /* end -1: none */
    double bend[16], pressure[16], slide[16];
    int mpe;
    hg_zones zones;
} hg_alloc;

static void hg_alloc_reset(hg_alloc *a)
{
    int v, c;
    for (v = 0; v < a->count; v++) {
        for (c = 0; c < HG_COLUMNS; c++) a->rows[v][c] = 0.0;
        a->rows[v][HG_NOTE] = 69.0;
        a->rows[v][HG_SLIDE] = HG_MIDDLE;
        a->zone_of[v] = a->owner[v] = -1;
        a->own[v] = 0.0;
        a->held[v] = 0;
        a->since[v] = v - a->count;
        a->end[v] = -1;
    }
    if (a->mpe) hg_zones_reset(&a->zones);
    a->clock = a->seq = 0;
    a->done = -1;
    for (c = 0; c < 16; c++) { a->bend[c] = a->pressure[c] = 0.0; a->slide[c] = HG_MIDDLE; }
}

static void hg_release(hg_alloc *a, int v)
{
    int u, channel = a->owner[v] / 128;
    a->held[v] = 0;
    a->since[v] = a->clock++;
    a->rows[v][HG_GATE] = 0.0;
    a->end[v] = -1;
    if (!a->mpe || hg_is_master(&a->zones, channel)) return;
    for (u = 0; u < a->count; u++) if (a->held[u] && a->owner[u] / 128 == channel) return;
    hg_clear(&a->zones, channel);
}

static int hg_voice_for(const hg_alloc *a, int note)
{
    int v, best = -1, free = 0;
    for (v = 0; v < a->count; v++) {
        if (a->held[v] && a->owner[v] == note) return v;
        if (!a->held[v]) free = 1;
    }
    for (v = 0; v < a->count; v++)
        if ((!free || !a->held[v]) && (best < 0 || a->since[v] < a->since[best])) best = v;
    return best;
}

static void hg_strike(hg_alloc *a, int v, const hg_msg *m)
{
    int c = hg_channel(m), z;
    double *row = a->rows[v];
    if (!a->mpe) {
        row[HG_GATE] = 1.0; row[HG_NOTE] = m->b[1]; row[HG_BEND] = a->bend[c]; row[HG_VELOCITY] = m->b[2] / 127.0;
        row[HG_PRESSURE] = 0.0; row[HG_SLIDE] = a->slide[c]; row[HG_DETUNE] = 0.0;
        return;
    }
    z = hg_zone_of(&a->zones, c);
    a->zone_of[v] = z;
    a->own[v] = hg_own(&a->zones, c);
    row[HG_GATE] = 1.0; row[HG_NOTE] = m->b[1]; row[HG_BEND] = 0.0; row[HG_VELOCITY] = m->b[2] / 127.0;
    row[HG_PRESSURE] = a->zones.pressure[c]; row[HG_SLIDE] = a->zones.slide[c];
    row[HG_DETUNE] = a->own[v] + hg_common(&a->zones, z);
}

static void hg_key_pressure(hg_alloc *a, const hg_msg *m)
{
    int v;
    for (v = 0; v < a->count; v++)
        if (a->held[v] && a->owner[v] == hg_channel(m) * 128 + m->b[1]) a->rows[v][HG_PRESSURE] = m->b[2] / 127.0;
}

static void hg_retune(hg_alloc *a)
{
    int v;
    hg_zones *z = &a->zones;
    for (v = 0; v < a->count; v++) {
        if (a->owner[v] < 0 || a->zone_of[v] < 0) continue;
        if (a->held[v] && hg_zone_of(z, a->owner[v] / 128) == a->zone_of[v]) a->own[v] = hg_own(z, a->owner[v] / 128);
        a->rows[v][HG_DETUNE] = a->own[v] + hg_common(z, a->zone_of[v]);
    }
}

/* MPE: the sample's RPN messages applied, then the others the zones play kept (all-notes-off on
   a master channel spread over its zone): their count, in r->msg */
static int hg_zone_messages(hg_alloc *a, hg_scratch *r, int n)
{
    int k, v, c, kept = 0, ranges;
    hg_zones *z = &a->zones;
    unsigned char moved[16];
    for (k = 0; k < n; k++) {
        if (hg_kind(&r->msg[k]) != 11 || !HG_IS_RPN(r->msg[k].b[1])) continue;
        memset(moved, 0, sizeof moved);
        ranges = hg_configure(z, &r->msg[k], moved);
        for (v = 0; v < a->count; v++) if (a->held[v] && moved[a->owner[v] / 128]) hg_release(a, v);
        if (ranges) hg_retune(a);
    }
    memcpy(r->given, r->msg, (size_t)n * sizeof r->msg[0]);
    for (k = 0; k < n; k++) {
        hg_msg m = r->given[k];
        c = hg_channel(&m);
        if ((hg_kind(&m) == 11 && HG_IS_RPN(m.b[1])) || hg_zone_of(z, c) < 0) continue;
        if (hg_kind(&m) == 11 && HG_IS_ALL_OFF(m.b[1]) && hg_is_master(z, c)) {
            int zone = hg_zone_of(z, c), d;
            for (d = 0; d < 16; d++)
                if (z->zone[d] == zone) { r->msg[kept] = m; r->msg[kept++].b[0] = (unsigned char)(0xB0 | d); }
        } else {
            r->msg[kept++] = m;
        }
    }
    return kept;
}

static void hg_expression(hg_alloc *a, const hg_msg *m)
{
    hg_zones *z = &a->zones;
    int c = hg_channel(m), kind = hg_kind(m), column, master, zone, v;
    if (kind == 14) column = HG_DETUNE;
    else if (kind == 13) column = HG_PRESSURE;
    else if (hg_cc(m, HG_SLIDE_CC)) column = HG_SLIDE;
    else { if (kind == 10) hg_key_pressure(a, m); return; }
    if (kind == 14) z->bend[c] = hg_bend_of(m) / 8192.0;
    else if (kind == 13) z->pressure[c] = m->b[1] / 127.0;
    else z->slide[c] = m->b[2] / 127.0;
    master = hg_is_master(z, c);
    zone = hg_zone_of(z, c);
    for (v = 0; v < a->count; v++) {
        if (master ? !(a->owner[v] >= 0 && a->zone_of[v] == zone) : !(a->held[v] && a->owner[v] / 128 == c)) continue;
        if (column == HG_DETUNE) {
            if (!master) a->own[v] = hg_own(z, c);
            a->rows[v][HG_DETUNE] = a->own[v] + hg_common(z, a->zone_of[v]);
        } else {
            a->rows[v][column] = column == HG_PRESSURE ? z->pressure[c] : z->slide[c];
        }
    }
}

static void hg_control(hg_alloc *a, const hg_msg *m)
{
    int c = hg_channel(m), v, column = -1;
    double value = 0.0;
    if (a->mpe) { hg_expression(a, m); return; }
    if (hg_kind(m) == 14) { a->bend[c] = hg_bend_of(m) / 8192.0; column = HG_BEND; value = a->bend[c]; }
    else if (hg_kind(m) == 13) { a->pressure[c] = m->b[1] / 127.0; column = HG_PRESSURE; value = a->pressure[c]; }
    else if (hg_cc(m, HG_SLIDE_CC)) { a->slide[c] = m->b[2] / 127.0; column = HG_SLIDE; value = a->slide[c]; }
    else if (hg_kind(m) == 10) hg_key_pressure(a, m);
    if (column >= 0)
        for (v = 0; v < a->count; v++) if (a->owner[v] >= 0 && a->owner[v] / 128 == c) a->rows[v][column] = value;
}

/* every event of absolute sample `at` (n messages in r->msg) and the ends due there; the voices
   whose gate dips at the sample before (into dips, each once: at most a->count), their count */
static int hg_alloc_at(hg_alloc *a, hg_scratch *r, int n, long long at, int *dips)
{
    double before[HG_VOICES];
    unsigned char dipped[HG_VOICES];        /* a voice stolen twice at one sample dips once */
    int v, k, first, n_dips = 0;
    for (v = 0; v < a->count; v++) { before[v] = a->rows[v][HG_GATE]; dipped[v] = 0; }
    for (;;) {                              /* the ends due, in the order they were set */
        for (first = -1, v = 0; v < a->count; v++)
            if (a->end[v] >= 0 && a->end[v] <= at && (first < 0 || a->end_seq[v] < a->end_seq[first])) first = v;
        if (first < 0) break;
        hg_release(a, first);
    }
    if (a->mpe) n = hg_zone_messages(a, r, n);
    for (v = 0; v < a->count; v++) if (a->held[v]) r->held[a->owner[v]] = 1;
    hg_resolve(r, n);
    for (v = 0; v < a->count; v++) if (a->held[v]) r->held[a->owner[v]] = 0;
    for (k = 0; k < r->n_ended; k++)
        for (v = 0; v < a->count; v++)
            if (a->held[v] && a->owner[v] == r->ended[k]) { hg_release(a, v); break; }
    for (k = 0; k < r->n_struck; k++) {
        int note = r->struck[k];
        v = hg_voice_for(a, note);
        hg_strike(a, v, &r->msg[r->struck_msg[note]]);
        a->owner[v] = note;
        a->held[v] = 1;
        a->since[v] = a->clock++;
        a->end[v] = -1;
        if (before[v] > 0.0 && !dipped[v]) { dipped[v] = 1; dips[n_dips++] = v; }
        if (r->is_short[note]) { a->end[v] = at + 1; a->end_seq[v] = a->seq++; }
    }
    for (k = 0; k < n; k++) hg_control(a, &r->msg[k]);
    hg_resolved(r);
    return n_dips;
}

/* ---- the instance's MIDI: the queue and every block reading it */
typedef struct {
    hg_event q[HG_QUEUE];                   /* in order of their sample, then as given */
    int n;
    long long seen;                         /* the last sample a block has read */
    hg_note_tap notes[HG_N_NOTES + 1];
    hg_cc_tap ccs[HG_N_CCS + 1];
    hg_alloc allocs[HG_N_ALLOCS + 1];
    hg_scratch r;
} hg_midi;

static void hg_midi_reset(hg_midi *mi)
{
    int k;
    mi->n = 0;
    mi->seen = -1;
    memset(&mi->r, 0, sizeof mi->r);
    for (k = 0; k < HG_NOTES; k++) mi->r.struck_msg[k] = -1;
    for (k = 0; k < HG_N_NOTES; k++) hg_note_reset(&mi->notes[k]);
    for (k = 0; k < HG_N_CCS; k++) mi->ccs[k].value = 0.0;
    for (k = 0; k < HG_N_ALLOCS; k++) hg_alloc_reset(&mi->allocs[k]);
}

/* 0: queued (or not a channel message: ignored); -1: the queue is full; -2: not a MIDI message */
static int hg_midi_give(hg_midi *mi, long long at, const unsigned char *bytes, int len)
{
    static const int size[8] = {3, 3, 3, 3, 2, 2, 3, 0};
    int k, need;
    if (bytes == NULL || len < 1 || bytes[0] < 0x80) return -2;
    need = size[(bytes[0] >> 4) - 8];
    if (need == 0) return 0;                /* a system message: no block reads it */
    if (len < need) return -2;
    for (k = 1; k < need; k++) if (bytes[k] >= 0x80) return -2;
    if (mi->n >= HG_QUEUE) return -1;
    if (at <= mi->seen) at = mi->seen + 1;
    for (k = mi->n; k > 0 && mi->q[k - 1].at > at; k--) mi->q[k] = mi->q[k - 1];
    mi->q[k].at = at;
    mi->q[k].b[0] = bytes[0]; mi->q[k].b[1] = bytes[1]; mi->q[k].b[2] = need == 3 ? bytes[2] : 0;
    mi->n++;
    return 0;
}

static int hg_mine(int channel, const hg_event *e) { return channel < 0 || (e->b[0] & 15) == channel; }

/* the messages of sample `at` a block on `channel` reads, from queue index *k on, into r->msg */
static int hg_gather(const hg_midi *mi, hg_scratch *r, int *k, long long at, int channel)
{
    int n = 0;
    for (; *k < mi->n && mi->q[*k].at == at; (*k)++)
        if (hg_mine(channel, &mi->q[*k])) memcpy(r->msg[n++].b, mi->q[*k].b, 3);
    return n;
}

static void hg_hold(double (*col)[HG_CHUNK], int first, const double *row, int width, int from, int to)
{
    int c, i;
    for (c = 0; c < width; c++) for (i = from; i < to; i++) col[first + c][i] = row[c];
}

static void hg_note_fill(hg_midi *mi, hg_note_tap *p, long long t0, int n, double (*col)[HG_CHUNK])
{
    int cursor = 0, k = 0, i, e, m;
    for (;;) {
        long long next = LLONG_MAX;
        while (k < mi->n && mi->q[k].at < t0 + n && !hg_mine(p->channel, &mi->q[k])) k++;
        if (k < mi->n && mi->q[k].at < t0 + n) next = mi->q[k].at;
        for (e = 0; e < p->n_ends; e++) if (p->end_at[e] < t0 + n && p->end_at[e] < next) next = p->end_at[e];
        if (next == LLONG_MAX) break;
        i = next < t0 ? 0 : (int)(next - t0);
        hg_hold(col, p->col, p->row, HG_COLUMNS, cursor, i);
        cursor = i;
        m = hg_gather(mi, &mi->r, &k, t0 + i, p->channel);
        hg_note_at(p, &mi->r, m, t0 + i);
    }
    hg_hold(col, p->col, p->row, HG_COLUMNS, cursor, n);
}

static void hg_cc_fill(const hg_midi *mi, hg_cc_tap *p, long long t0, int n, double (*col)[HG_CHUNK])
{
    int cursor = 0, k, i;
    for (k = 0; k < mi->n && mi->q[k].at < t0 + n; k++) {
        const hg_event *e = &mi->q[k];
        if ((e->b[0] >> 4) != 11 || e->b[1] != p->number || !hg_mine(p->channel, e)) continue;
        i = e->at < t0 ? 0 : (int)(e->at - t0);
        hg_hold(col, p->col, &p->value, 1, cursor, i);
        cursor = i;
        p->value = e->b[2] / 127.0;
    }
    hg_hold(col, p->col, &p->value, 1, cursor, n);
}

static void hg_alloc_fill(hg_midi *mi, hg_alloc *a, long long t0, int n, double (*col)[HG_CHUNK])
{
    int cursor = 0, k = 0, i, v, m, n_dips, dips[HG_VOICES];
    for (;;) {
        long long next = LLONG_MAX;
        while (k < mi->n && mi->q[k].at <= t0 + n && (mi->q[k].at <= a->done || !hg_mine(a->channel, &mi->q[k]))) k++;
        if (k < mi->n && mi->q[k].at <= t0 + n) next = mi->q[k].at;
        for (v = 0; v < a->count; v++)
            if (a->end[v] >= 0 && a->end[v] <= t0 + n && a->end[v] > a->done && a->end[v] < next) next = a->end[v];
        if (next == LLONG_MAX) break;
        i = next < t0 ? 0 : (int)(next - t0);
        for (v = 0; v < a->count; v++) if (a->col[v] >= 0) hg_hold(col, a->col[v], a->rows[v], HG_COLUMNS, cursor, i);
        cursor = i;
        m = hg_gather(mi, &mi->r, &k, t0 + i, a->channel);
        n_dips = hg_alloc_at(a, &mi->r, m, t0 + i, dips);
        for (v = 0; v < n_dips; v++) if (i > 0 && a->col[dips[v]] >= 0) col[a->col[dips[v]] + HG_GATE][i - 1] = 0.0;
        a->done = t0 + i;
    }
    for (v = 0; v < a->count; v++) if (a->col[v] >= 0) hg_hold(col, a->col[v], a->rows[v], HG_COLUMNS, cursor, n);
}

/* the columns of samples t0 ... t0+n-1 (n <= HG_CHUNK); the events before t0+n are then played */
static void hg_midi_fill(hg_midi *mi, long long t0, int n, double (*col)[HG_CHUNK])
{
    int k, kept;
    for (k = 0; k < HG_N_NOTES; k++) hg_note_fill(mi, &mi->notes[k], t0, n, col);
    for (k = 0; k < HG_N_CCS; k++) hg_cc_fill(mi, &mi->ccs[k], t0, n, col);
    for (k = 0; k < HG_N_ALLOCS; k++) hg_alloc_fill(mi, &mi->allocs[k], t0, n, col);
    mi->seen = t0 + n - (HG_N_ALLOCS > 0 ? 0 : 1);
    for (k = 0; k < mi->n && mi->q[k].at < t0 + n; k++) ;
    kept = mi->n - k;
    memmove(mi->q, mi->q + k, (size_t)kept * sizeof mi->q[0]);
    mi->n = kept;
}
