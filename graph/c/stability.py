"""The mass-spring stability check at the host's rate: `NAME_refused` refuses a rate at which
`hapticgraph check` would refuse the patch, with check's words. What the check reads of the rate
is computed at export (blocks/massspring/checks.py `rate_limits`: per group, the cells that can
be the worst at some rate and the links with a mass of their own, as numbers); what it computes
from the rate — the time step, the stability number, the hints — is its own Python translated
(`time_step`, `stability_number`, `stiffness_budget`, `largest_tension`, `smallest_mass`), and
its problems are its own %-formats (UNSTABLE, OWN_MASS, the hints), written with snprintf."""
import os

from ...blocks.massspring import MassSpring
from ...blocks.massspring.checks import (JOINS_HINT, MASS_HINT, OWN_MASS, STABILITY_BOUND, TENSION_HINT, UNSTABLE,
                                         largest_tension, own_masses, rate_limits, smallest_mass, stability_number,
                                         stiffness_budget)
from ...blocks.massspring.steps import time_step
from ..family import members
from .api import c_string
from .values import Refused, Val, literal


class _Caller:
    """What the library's `call` refuses through, for a call written here."""

    def __init__(self, fn):
        self.fn = fn

    def refuse(self, message, node=None):
        code = self.fn.__code__
        raise Refused(code.co_filename, code.co_firstlineno, message)


def _call(lib, fn, *args):
    """C text of fn(*args), fn translated (args: C text of doubles)."""
    return lib.call(fn, [Val("f", a) for a in args], _Caller(fn)).c


def _f(value):
    return literal(float(value))


def stability_source(lib, patch):
    """`static int hg_stability(double fs, hg_why *w)`: 1 (and each problem said) when the patch's
    mass-spring groups are unstable at fs."""
    prefix = os.path.basename(str(patch.file)).replace("%", "%%")
    bound = _f(STABILITY_BOUND)
    body = []
    for springs, candidates in rate_limits(members(patch.blocks, MassSpring), float(patch.rate)):
        for s, law, slope in own_masses(springs):
            number = _call(lib, stability_number, "dt", _f(slope), _f(s.values["mass"]), "0.0")
            body += [f"    number = {number};", f"    if (number >= {bound}) {{", "        bad = 1;",
                     f"        hg_say(w, {c_string(f'{prefix}:{s.line}: ' + OWN_MASS)}, {c_string(repr(s.name))}, "
                     f"{c_string(s.cls.type_name)}, fs, {_f(s.values['mass'])}, {c_string(law)}, {_f(slope)}, number, "
                     f"{bound});", "    }"]
        if candidates:
            body += _candidates(lib, candidates, prefix, bound)
    lines = ["static int hg_stability(double fs, hg_why *w)", "{", "    int bad = 0;"]
    if body:
        lines += ["    double dt, number, budget, most;", "    int i, at;", "    char hint[256], hints[1024];",
                  f"    dt = {_call(lib, time_step, 'fs')};"] + body
    lines += ["    (void)fs; (void)w;", "    return bad;", "}", ""]
    return "\n".join(lines)


def _candidates(lib, candidates, prefix, bound):
    """The first candidate with the largest stability number; its problem when it reaches the bound."""
    n = len(candidates)
    table = ", ".join(f"{{{_f(c.stiffness)}, {_f(c.mass)}, {_f(c.damping)}}}" for c in candidates)
    number = _call(lib, stability_number, "dt", "hg_c[i][0]", "hg_c[i][1]", "hg_c[i][2]")
    out = ["    {", f"        static const double hg_c[{n}][3] = {{{table}}};", "        most = 0.0;", "        at = -1;",
           f"        for (i = 0; i < {n}; i++) {{", f"            number = {number};",
           "            if (at < 0 || number > most) { most = number; at = i; }", "        }",
           f"        if (most >= {bound}) {{", "            bad = 1;", "            switch (at) {"]
    for i, c in enumerate(candidates):
        out.append(f"            case {i}:")
        mass_hint = _call(lib, smallest_mass, "dt", _f(c.stiffness), _f(c.damping))
        if c.tension is not None:
            budget = _call(lib, stiffness_budget, "dt", _f(c.mass), _f(c.damping))
            tension = _call(lib, largest_tension, _f(c.tension), "budget", _f(c.own), _f(c.join))
            out += [f"                budget = {budget};",
                    f"                if (budget > {_f(c.join)}) hg_format(hint, (int)sizeof hint, {c_string(TENSION_HINT)}, "
                    f"{tension});",
                    f"                else hg_format(hint, (int)sizeof hint, \"%s\", {c_string(JOINS_HINT)});",
                    f"                hg_format(hints, (int)sizeof hints, {c_string('%s; ' + MASS_HINT)}, hint, "
                    f"{c_string(c.of_cell)}, {mass_hint});"]
        else:
            out.append(f"                hg_format(hints, (int)sizeof hints, {c_string(MASS_HINT)}, {c_string(c.of_cell)}, "
                       f"{mass_hint});")
        out += [f"                hg_say(w, {c_string(f'{prefix}:{c.inst.line}: ' + UNSTABLE)}, "
                f"{c_string(repr(c.inst.name))}, {c_string(c.inst.cls.type_name)}, fs, {c_string(c.label)}, most, "
                f"{bound}, hints);", "                break;"]
    out += ["            }", "        }", "    }"]
    return out


__all__ = ["stability_source"]
