"""The life of an exported instance: NAME_new (the host's rate checked, derived and checked again
at that rate, rings allocated: the only allocation), _reset, _free, _process (pending parameter
changes applied, then the translated kernel over n samples), _set and _get. `plan` is a
graph/c/export.CPlan."""
from .api import CHUNK, c_string
from .values import array_kind, literal


def refused(plan):
    """NAME_refused: every reason NAME_new has to refuse a rate, said."""
    n, low, high = plan.name, literal(plan.rates[0]), literal(plan.rates[1])
    outside = f"rate %g Hz: outside the {plan.rates[0]:g} to {plan.rates[1]:g} Hz a patch may run at"
    lines = [f"int {n}_refused(double rate, char *why, int size)", "{", "    hg_why w;",
             f"    double coef[{max(1, len(plan.coef))}];", "    int bad;",
             "    w.p = why; w.size = size; w.used = 0;", "    if (why != NULL && size > 0) why[0] = 0;",
             f"    if (!(rate >= {low} && rate <= {high})) {{",
             f"        hg_say(&w, {c_string(outside)}, rate);",
             "        return 1;", "    }"]
    if plan.fixed_rate:
        lines += [f"    if (rate != {literal(plan.rate)}) {{",
                  f"        hg_say(&w, {c_string(f'rate %g Hz: {plan.fixed_rate} ({plan.rate:g} Hz)')}, rate);",
                  "        return 1;", "    }"]
    lines += ["    memcpy(coef, hg_coef0, sizeof coef);",
              "    bad = hg_stability(rate, &w);", "    bad |= hg_check_all(hg_live0, rate, &w);",
              "    bad |= hg_derive_all(hg_live0, rate, coef, &w);", "    return bad;", "}", ""]
    return "\n".join(lines)


def new(plan):
    n, lines = plan.name, []
    lines += [f"{n} *{n}_new(double rate)", "{", f"    {n} *s;", f"    if ({n}_refused(rate, NULL, 0)) return NULL;"]
    lines += [f"    s = ({n} *)calloc(1, sizeof *s);", "    if (s == NULL) return NULL;", "    s->rate = rate;",
              "    memcpy(s->live, hg_live0, sizeof s->live);", "    memcpy(s->next_live, hg_live0, sizeof s->next_live);",
              "    memcpy(s->coef, hg_coef0, sizeof s->coef);"]
    if plan.rate_slot is not None:
        lines.append(f"    s->coef[{plan.rate_slot}] = rate;")
    lines += ["    " + line for line in plan.rated]
    lines.append("    (void)hg_derive_all(s->live, rate, s->coef, NULL);")
    for k, size in enumerate(plan.buffers):
        lines.append(f"    s->buf[{k}].n = hg_capacity({size});")
        lines.append(f"    s->buf[{k}].p = (double *)calloc((size_t)s->buf[{k}].n, sizeof(double));")
        lines.append(f"    if (s->buf[{k}].p == NULL) {{ {n}_free(s); return NULL; }}")
    if plan.hosted is not None:
        lines += ["    " + line for line in plan.hosted.new]
    lines += [f"    {n}_reset(s);", "    return s;", "}", ""]
    return "\n".join(lines)


def reset(plan):
    n = plan.name
    lines = [f"void {n}_reset({n} *s)", "{", "    s->t = 0;"]
    for slot, value in enumerate(plan.state):
        lines.append(f"    s->state[{slot}] = {value};")
    for k in range(len(plan.buffers)):
        lines.append(f"    memset(s->buf[{k}].p, 0, (size_t)s->buf[{k}].n * sizeof(double));")
    for k in range(len(plan.arrays)):
        lines.append(f"    memcpy(s->a{k}, hg_a{k}_init, sizeof s->a{k});")
    lines += ["    " + line for line in plan.rows]      # the groups' rows at this rate
    if plan.hosted is not None:
        lines += ["    " + line for line in plan.hosted.reset]
    return "\n".join(lines + ["}", ""])


def free(plan):
    n = plan.name
    lines = [f"void {n}_free({n} *s)", "{", "    if (s == NULL) return;"]
    lines += [f"    free(s->buf[{k}].p);" for k in range(len(plan.buffers))]
    return "\n".join(lines + ["    free(s);", "}", ""])


def process(plan):
    """NAME_process: the kernel over the host's columns; with hosted columns (NAME_midi's), a
    static hg_run is that, and NAME_process runs it CHUNK samples at a time, the hosted columns
    computed for each chunk first."""
    if plan.hosted is not None:
        return _run(plan, "static int hg_run") + _chunked(plan)
    return _run(plan, f"int {plan.name}_process")


def _chunked(plan):
    n, nout = plan.name, len(plan.outputs)
    cols = [f"s->hcol[{k}]" if j is None else f"in[{j}] + done" for k, j in enumerate(plan.ext_in)]
    lines = [f"int {n}_process({n} *s, const double *const *in, double *const *out, int n)", "{",
             f"    const double *col[{max(1, len(cols))}];", f"    double *o[{max(1, nout)}];",
             "    int done, m, c, k, r, code = 0;", "    (void)in; (void)c; (void)k;",
             "    for (done = 0; done < n; done += m) {", f"        m = n - done < {CHUNK} ? n - done : {CHUNK};",
             f"        {plan.hosted.fill}"]
    lines += [f"        col[{k}] = {c};" for k, c in enumerate(cols)]
    lines += [f"        for (c = 0; c < {nout}; c++) o[c] = out[c] + done;",
              "        r = hg_run(s, (const double *const *)col, o, m);", "        if (code == 0) code = r;", "    }"]
    lines += _zero_forces(plan, "0.0")
    return "\n".join(lines + ["    return code;", "}", ""])


def _zero_forces(plan, zero):
    """After a call of n samples in chunks: on a fault, every force column of the call is `zero`."""
    forces = [c for c, p in enumerate(plan.outputs) if p.kind == "cv"]
    if not forces:
        return []
    return ["    if (code != 0) for (k = 0; k < n; k++) { " + " ".join(f"out[{c}][k] = {zero};" for c in forces) + " }"]


def midi(plan):
    """NAME_midi: the hosted driver's events (hapticgraph.devices.midi_c), or none to take."""
    n = plan.name
    body = [f"    {plan.hosted.give}"] if plan.hosted is not None else [
        "    (void)s; (void)offset;", "    if (bytes == NULL || len < 1 || bytes[0] < 0x80) return -2;",
        "    return 0;                 /* no block of the patch reads MIDI */"]
    return "\n".join([f"int {n}_midi({n} *s, int offset, const unsigned char *bytes, int len)", "{"] + body + ["}", ""])


def _run(plan, signature):
    n = plan.name
    args = ["(long long)n", "s->t", f"hg_view(s->state, {len(plan.state)})", f"hg_view(s->live, {len(plan.live)})",
            f"hg_view(s->coef, {len(plan.coef)})", "rec", "ext"]
    args += [f"s->buf[{k}]" for k in range(len(plan.buffers))]
    args += [_view(k, a) for k, a in enumerate(plan.arrays)]
    lines = [f"{signature}({n} *s, const double *const *in, double *const *out, int n)", "{",
             "    hg_rec rec;", "    hg_ext ext;", "    long long code;", "    hg_fpenv saved;",
             "    if (n <= 0) return 0;", "    if (s->dirty) hg_apply(s);",
             f"    rec.col = out; rec.n = n; rec.m = {len(plan.outputs)};",
             f"    ext.col = in; ext.n = n; ext.m = {len(plan.ext_in)};",
             "    saved = hg_flush_enter();" if plan.flush_outside else "    saved = 0;",
             f"    code = hg_kernel({', '.join(args)});",
             "    hg_flush_exit(saved);" if plan.flush_outside else "    (void)saved;",
             "    s->t += n;",
             "    return code > INT_MAX ? INT_MAX : code < INT_MIN ? INT_MIN : (int)code;", "}", ""]
    return "\n".join(lines)


def process_float(plan):
    """NAME_process_float: float columns converted to double through the instance's buffers,
    CHUNK samples at a time, NAME_process over them, each output rounded once to float; on a
    fault the forces of the whole call are zero, as NAME_process's."""
    n, nin, nout = plan.name, len(plan.inputs), len(plan.outputs)
    lines = [f"int {n}_process_float({n} *s, const float *const *in, float *const *out, int n)", "{",
             f"    double *pin[{max(1, nin)}], *pout[{max(1, nout)}];", "    int done, m, k, c, r, code = 0;",
             f"    for (c = 0; c < {nin}; c++) pin[c] = s->fin[c];",
             f"    for (c = 0; c < {nout}; c++) pout[c] = s->fout[c];",
             f"    for (done = 0; done < n; done += m) {{", f"        m = n - done < {CHUNK} ? n - done : {CHUNK};",
             f"        for (c = 0; c < {nin}; c++) for (k = 0; k < m; k++) s->fin[c][k] = (double)in[c][done + k];",
             f"        r = {n}_process(s, (const double *const *)pin, pout, m);", "        if (code == 0) code = r;",
             f"        for (c = 0; c < {nout}; c++) for (k = 0; k < m; k++) out[c][done + k] = (float)s->fout[c][k];",
             "    }"]
    lines += _zero_forces(plan, "0.0f")
    lines += ["    (void)pin; (void)pout;", "    return code;", "}", ""]
    return "\n".join(lines)


VIEWS = {"arr": "hg_view", "iarr": "hg_iview", "i32arr": "hg_i32view", "u32arr": "hg_u32view"}


def _view(k, array):
    """The kernel's argument of array k: a view of the instance's copy."""
    kind = array_kind(array)
    if kind == "arr2":
        return f"hg_view2(s->a{k}, {array.shape[0]}, {array.shape[1]})"
    return f"{VIEWS[kind]}(s->a{k}, {array.size})"


def set_get(plan):
    n, count = plan.name, len(plan.params)
    return "\n".join([
        f"int {n}_set({n} *s, int index, double value)", "{", "    int slot;",
        f"    if (index < 0 || index >= {count} || hg_live_slot[index] < 0) return -1;",
        "    if (!hg_in_range(index, value)) return -2;",
        "    slot = hg_live_slot[index];",
        "    memcpy(s->scratch_live, s->next_live, sizeof s->scratch_live);",
        "    memcpy(s->scratch_coef, s->coef, sizeof s->scratch_coef);",
        "    s->scratch_live[slot] = value;",
        "    if (hg_derive_all(s->scratch_live, s->rate, s->scratch_coef, NULL)) return -3;",
        "    s->next_live[slot] = value;", "    s->dirty = 1;", "    return 0;", "}", "",
        f"double {n}_get(const {n} *s, int index)", "{",
        f"    if (index < 0 || index >= {count}) return NAN;",
        f"    return hg_live_slot[index] >= 0 ? s->next_live[hg_live_slot[index]] : {n}_params[index].def;", "}", ""])


__all__ = ["free", "midi", "new", "process", "process_float", "refused", "reset", "set_get"]
