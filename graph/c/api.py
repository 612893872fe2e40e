"""The exported C API around the translated kernel: the header, the instance's struct (everything
an instance holds, allocated once by NAME_new: no globals but constant tables, any number of
instances), the port and parameter tables, and NAME_new / _free / _reset / _process / _set / _get.
`plan` is a graph/c/export.CPlan."""
from .values import NUMBER_ARRAYS, array_kind, literal

CHUNK = 256     # NAME_process_float's buffers: samples converted at a time

HEADER = """\
/* {title}: a hapticgraph patch exported to C99 (libm only). Generated; do not edit.
   {name}_new(rate) makes an instance (NULL where the patch refuses the rate); {name}_process(s, in, out, n)
   runs n samples: in[k][i] is input column k (the ports whose `input` is 1, in order), out[k][i]
   output column k (the others, in order); it returns 0, or the safety check's fault code (the
   forces of that call are then zero). {name}_set(s, index, value) changes live parameter `index`
   of {name}_params from the next call on: 0, or -1 (not a live parameter), -2 (out of range),
   -3 (it would change the kernel's structure). {name}_refused(rate, why, size) says why {name}_new
   refuses a rate (as `hapticgraph check` says it of the patch at that rate). */
#ifndef {guard}
#define {guard}
#ifdef __cplusplus
extern "C" {{
#endif

typedef struct {name} {name};
typedef struct {{ const char *name; int input; const char *kind; const char *unit; }} {name}_port;
typedef struct {{ const char *name; const char *unit; double min, max, def; int live; }} {name}_param;

#define {upper}_RATE {rate}
#define {upper}_N_INPUTS {inputs}
#define {upper}_N_OUTPUTS {outputs}
#define {upper}_N_PARAMS {params}
#define {upper}_MIDI {midi}            /* 1: {name}_midi plays the patch's midi_note / midi_cc blocks */

extern const {name}_port {name}_ports[];     /* inputs, then outputs; a NULL name ends it */
extern const {name}_param {name}_params[];   /* a NULL name ends it */

{name} *{name}_new(double rate);
int {name}_refused(double rate, char *why, int size);   /* 0, or 1 and why (one problem a line, at most size bytes) */
void {name}_free({name} *s);
void {name}_reset({name} *s);
int {name}_process({name} *s, const double *const *in, double *const *out, int n);
int {name}_process_float({name} *s, const float *const *in, float *const *out, int n);   /* the same in float */
int {name}_set({name} *s, int index, double value);
double {name}_get(const {name} *s, int index);
/* a MIDI channel message (status byte first, no running status) at sample `offset` of the next
   {name}_process call: 0 (a system message is ignored), -1 (too many events waiting), -2 (not one) */
int {name}_midi({name} *s, int offset, const unsigned char *bytes, int len);

#ifdef __cplusplus
}}
#endif
#endif
"""


def c_string(text):
    """A C string literal of `text` (UTF-8; quotes, backslashes and every byte outside printable
    ASCII escaped)."""
    out = []
    for b in str(text).encode("utf-8"):
        c = chr(b)
        out.append(f"\\{b:03o}" if b < 32 or b > 126 or c in '"\\?' else c)
    return '"' + "".join(out) + '"'


def header(plan):
    return HEADER.format(title=plan.title, name=plan.name, guard=plan.name.upper() + "_H", upper=plan.name.upper(),
                         rate=literal(plan.rate), inputs=len(plan.inputs), outputs=len(plan.outputs),
                         params=len(plan.params), midi=int(plan.hosted is not None))


def _floats(values):
    return "{" + ", ".join(literal(float(v)) for v in values) + "}" if len(values) else "{0}"


def tables(plan):
    """The public tables and the instance's first values."""
    n = plan.name
    lines = [f"const {n}_port {n}_ports[] = {{"]
    for p in plan.inputs + plan.outputs:
        lines.append(f"    {{{c_string(p.name)}, {int(p.input)}, {c_string(p.kind)}, {c_string(p.unit)}}},")
    lines += ["    {0, 0, 0, 0}", "};", f"const {n}_param {n}_params[] = {{"]
    for p in plan.params:
        lines.append(f"    {{{c_string(p.name)}, {c_string(p.unit)}, {literal(p.low)}, {literal(p.high)}, "
                     f"{literal(p.default)}, {int(p.slot >= 0)}}},")
    lines += ["    {0, 0, 0, 0, 0, 0}", "};"]
    lines.append(f"static const int hg_live_slot[] = {{{', '.join(str(p.slot) for p in plan.params) or '0'}}};")
    lines.append(f"static const double hg_live0[{max(1, len(plan.live))}] = {_floats(plan.live)};")
    lines.append(f"static const double hg_coef0[{max(1, len(plan.coef))}] = {_floats(plan.coef)};")
    for k, array in enumerate(plan.arrays):
        ctype = NUMBER_ARRAYS[array_kind(array)][1]
        flat = array.ravel()
        spelled = _floats(flat) if ctype == "double" else "{" + (", ".join(literal(int(v)) for v in flat) or "0") + "}"
        lines.append(f"static const {ctype} hg_a{k}_init[{max(1, flat.size)}] = {spelled};")
    return "\n".join(lines) + "\n"


def struct(plan):
    lines = [f"struct {plan.name} {{", "    double rate;", "    long long t;", "    int dirty;"]
    for field, size in (("state", len(plan.state)), ("live", len(plan.live)), ("next_live", len(plan.live)),
                        ("scratch_live", len(plan.live)), ("coef", len(plan.coef)), ("scratch_coef", len(plan.coef))):
        lines.append(f"    double {field}[{max(1, size)}];")
    lines.append(f"    hg_arr buf[{max(1, len(plan.buffers))}];")
    lines.append(f"    double fin[{max(1, len(plan.inputs))}][{CHUNK}], fout[{max(1, len(plan.outputs))}][{CHUNK}];")
    if plan.hosted is not None:
        lines += [f"    double hcol[{len(plan.ext_in)}][{CHUNK}];", f"    {plan.hosted.field}"]
    for k, array in enumerate(plan.arrays):
        lines.append(f"    {NUMBER_ARRAYS[array_kind(array)][1]} a{k}[{max(1, array.size)}];")
    return "\n".join(lines + ["};"]) + "\n"


def _all(calls, args):
    """Each call; a refusal said (`w`, NULL: not said), and 1 returned when one refused."""
    lines = "".join(f"    if ({c}({args})) {{ bad = 1; hg_say(w, {c_string(said)}, fs); }}\n" for c, said in calls)
    return "    int bad = 0;\n" + lines + "    (void)w;\n    return bad;\n"


def setup_calls(plan):
    """hg_check_all, hg_derive_all (each saying what refuses the rate into `w`, NULL: nothing said),
    hg_in_range and hg_apply."""
    live = "const double *hg_live, double fs"
    out = [f"static int hg_check_all({live}, hg_why *w)\n{{\n{_all(plan.checks, 'hg_live, fs')}}}\n",
           f"static int hg_derive_all({live}, double *hg_coef, hg_why *w)\n{{\n"
           f"{_all(plan.derives, 'hg_live, fs, hg_coef')}}}\n"]
    cases = []
    for index, p in enumerate(plan.params):
        tests = [f"v {op} {literal(b)}" for op, b in p.bounds]
        if p.slot >= 0 and tests:
            cases.append(f"    case {index}: return {' && '.join(tests)};")
    out.append("static int hg_in_range(int index, double v)\n{\n    switch (index) {\n" + "\n".join(cases)
               + ("\n" if cases else "") + "    default: return 1;\n    }\n}\n")
    out.append(f"static void hg_apply({plan.name} *s)\n{{\n    memcpy(s->live, s->next_live, sizeof s->live);\n"
               "    (void)hg_derive_all(s->live, s->rate, s->coef, NULL);\n    s->dirty = 0;\n}\n")
    return "\n".join(out)


__all__ = ["c_string", "header", "setup_calls", "struct", "tables"]
