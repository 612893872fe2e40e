"""The IR of what a block reads (graph/ir.py): every node's kernel expression means what its
interpreter value says, and a live mass-spring parameter driven by several connections is their
sum on both engines."""
import io
import math
import re
import tokenize

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hapticgraph import render
from hapticgraph.graph.ir import (ArrayItem, ArrayRef, BufferItem, BufferRef, Coef, Column, Counter, DerivedCoef, Frame,
                                  Inverse, KernelSourceError, Literal, Live, Output, StateSlot, Total)
from hapticgraph.graph.modes import discrete_frequency
from hapticgraph.graph.patch import load

COEF_KINDS = ("float", "int", "bool")      # the kind of coefficient slot k is COEF_KINDS[k]
ATTRS = ("out", "left")
# full-mantissa values too (k/7), so that a lost pair of parentheses changes a rounding
FLOATS = st.one_of(st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=False),
                   st.integers(-10 ** 7, 10 ** 7).map(lambda k: k / 7.0))


@st.composite
def contexts(draw):
    """(frame, ext, i): the program's arrays and one sample's values, all random."""
    def vec(n):
        return np.array(draw(st.lists(FLOATS, min_size=n, max_size=n)))
    ext = np.array([vec(4) for _ in range(3)])
    i = draw(st.integers(0, 2))
    frame = Frame(state=vec(3), live=vec(3), coef=vec(3), buffers=[vec(4), vec(8)],
                  arrays=[vec(5) for _ in range(3)], t=draw(st.integers(0, 1 << 40)), ext_row=ext[i])
    frame.outs = {(k, a): draw(FLOATS) for k in range(3) for a in ATTRS}
    frame.derived = {k: {"a1": draw(FLOATS), "g": draw(FLOATS)} for k in range(3)}
    return frame, ext, i


LITERALS = st.one_of(FLOATS, st.integers(-1000, 1000), st.booleans(),
                     st.sampled_from([math.inf, -math.inf, math.nan, -0.0, 0.0]))


def _leaf(draw, derived=True):
    kinds = ["literal", "t", "live", "coef", "state", "item", "bitem", "column", "output"] + (["dcoef"] if derived else [])
    kind = draw(st.sampled_from(kinds))
    k3 = st.integers(0, 2)
    if kind == "literal":
        return Literal(draw(LITERALS))
    if kind == "t":
        return Counter()
    if kind == "live":
        return Live(draw(k3))
    if kind == "coef":
        slot = draw(k3)
        return Coef(slot, COEF_KINDS[slot])
    if kind == "state":
        return StateSlot(draw(k3))
    if kind == "item":
        return ArrayItem(draw(k3), Literal(draw(st.integers(0, 4))))
    if kind == "bitem":
        return BufferItem(draw(st.integers(0, 1)), draw(st.integers(0, 3)))
    if kind == "column":
        return Column(draw(st.integers(0, 3)))
    if kind == "output":
        return Output(draw(k3), draw(st.sampled_from(ATTRS)))
    return DerivedCoef(draw(k3), draw(st.sampled_from(["a1", "g"])))


def _tree(draw, frame, depth, derived=True):
    """A random scalar tree: sums (nested too) and inverses of nonzero values over leaves."""
    kind = draw(st.sampled_from(["leaf", "sum", "inverse"] if depth > 0 else ["leaf"]))
    if kind == "leaf":
        return _leaf(draw, derived)
    if kind == "sum":
        n = draw(st.integers(0, 4))
        return Total(tuple(_tree(draw, frame, depth - 1, derived) for _ in range(n)))
    of = _tree(draw, frame, depth - 1, derived)
    if of.value(frame) == 0:
        of = Literal(draw(st.sampled_from([2.0, -3, 0.1])))
    return Inverse(of)


def _namespace(frame, ext, i):
    """The kernel's locals and arguments at one sample, loaded as the kernel loads them."""
    ns = {"math": math, "t": frame.t, "i": i, "ext": ext}
    for k in range(3):
        ns[Live(k).emit()] = eval(Live(k).load(), {"live": frame.live})
        ns[StateSlot(k).emit()] = eval(StateSlot(k).load(), {"state": frame.state})
        c = Coef(k, COEF_KINDS[k])
        # numba's scalars add as Python's (True + True == 2), numpy's bools as a logical or
        loaded = eval(c.load(), {"coef": frame.coef})
        ns[c.emit()] = loaded.item() if isinstance(loaded, np.bool_) else loaded
        ns[ArrayRef(k).emit()] = frame.arrays[k]
        ns[f"d{k}"] = frame.derived[k]
        for a in ATTRS:
            ns[Output(k, a).emit()] = frame.outs[(k, a)]
    for k, b in enumerate(frame.buffers):
        ns[BufferRef(k).emit()] = b
    return ns


def _same(a, b):
    return a == b or (a != a and b != b)


NAMES = re.compile(r"t|i|ext|math|nan|inf|True|False|[slcabd]\d+|o\d+_[A-Za-z_]\w*")


@settings(max_examples=300, deadline=None)
@given(ctx=contexts(), data=st.data())
def test_emitted_expression_equals_interpreted_value(ctx, data):
    frame, ext, i = ctx
    tree = _tree(data.draw, frame, depth=4)
    text = tree.emit()
    with np.errstate(all="ignore"):
        expected = tree.value(frame)
        got = eval(text, _namespace(frame, ext, i))
    assert _same(got, expected), (text, got, expected)
    # the only names in kernel text are the compiler's: slots, indices, t, i, ext, math
    names = [tok.string for tok in tokenize.generate_tokens(io.StringIO(text).readline) if tok.type == tokenize.NAME]
    assert all(NAMES.fullmatch(name) for name in names), text


@settings(max_examples=30, deadline=None)
@given(ctx=contexts(), data=st.data())
def test_whole_arrays_and_tuples_are_passed_as_they_are(ctx, data):
    frame, ext, i = ctx
    node = data.draw(st.sampled_from([BufferRef(0), BufferRef(1), ArrayRef(2), Literal((0.25, 0.5, 0.25))]))
    got = eval(node.emit(), _namespace(frame, ext, i))
    expected = node.value(frame)
    assert got is expected or got == expected


@settings(max_examples=3, deadline=None)
@given(ctx=contexts(), data=st.data())
def test_numba_compiles_the_emitted_expressions_to_the_interpreted_values(ctx, data):
    """The same trees through numba (one function returning several), as in the kernel."""
    import numba
    frame, ext, i = ctx
    trees = [_tree(data.draw, frame, depth=3, derived=False) for _ in range(6)]
    ns = _namespace(frame, ext, i)
    outs = [Output(k, a).emit() for k in range(3) for a in ATTRS]
    lines = [f"def f(t, i, ext, live, coef, state, a0, a1, a2, b0, b1, {', '.join(outs)}):"]
    lines += [f"    {Live(k).emit()} = {Live(k).load()}" for k in range(3)]
    lines += [f"    {StateSlot(k).emit()} = {StateSlot(k).load()}" for k in range(3)]
    lines += [f"    {Coef(k, COEF_KINDS[k]).emit()} = {Coef(k, COEF_KINDS[k]).load()}" for k in range(3)]
    lines += [f"    return ({''.join(tree.emit() + ', ' for tree in trees)})"]
    scope = {"math": math}
    exec("\n".join(lines), scope)
    fn = numba.njit(scope["f"])
    got = fn(frame.t, i, ext, frame.live, frame.coef, frame.state, *frame.arrays, *frame.buffers,
             *[ns[o] for o in outs])
    for tree, value in zip(trees, got):
        with np.errstate(all="ignore"):
            assert _same(value, tree.value(frame)), tree.emit()


def test_inverse_of_a_sum_is_parenthesised():
    mass = Inverse(Total((Output(0, "out"), Output(1, "out"))))
    assert mass.emit() == "1.0 / (o0_out + o1_out)"
    assert Inverse(Live(2)).emit() == "1.0 / l2"
    assert Total((Live(0), Total((Live(1), Live(2))))).emit() == "l0 + (l1 + l2)"
    assert Total((Literal(-1.5), Literal(math.inf), Literal(-math.inf))).emit() == "(-1.5) + math.inf + (-math.inf)"
    assert Total(()).emit() == "0.0" and Total((Inverse(Live(0)),)).emit() == "1.0 / l0"


def test_names_in_emitted_code_are_identifiers_only():
    for bad in ("out; import os", "a-b", "", "ü"):
        with pytest.raises(KernelSourceError):
            Output(0, bad).emit()
        with pytest.raises(KernelSourceError):
            DerivedCoef(0, bad).emit()


# -- the engines agree: a lattice's mass wired from two blocks is their sum ---------------------

STRING = """\
hapticgraph: 1
rate: 44100
blocks:
  str:  {{type: lattice, shape: [60], mass: {mass!r}, tension: 144100.0, damping: 0.001, boundary: fixed{extra}}}
  half: {{type: constant, value: 0.0001}}
  rest: {{type: gain, gain: 0.5}}
  pick: {{type: pluck, time: 0.0, force: 1.0, duration: 0.001}}
connect:
  - pick.out -> str[12].force
  - half.out -> rest.in
"""
WIRED = "  - half.out -> str.mass\n  - rest.out -> str.mass\n"


@pytest.mark.parametrize("extra", ["", ", cells: [{index: [0], damping: 0.001}]"], ids=["stencil", "csr"])
def test_lattice_mass_from_two_connections_is_their_sum_on_both_engines(tmp_path, extra):
    mass = 0.0001 + 0.5 * 0.0001               # what the two connections sum to
    wired, plain = tmp_path / "wired.yaml", tmp_path / "plain.yaml"
    wired.write_text(STRING.format(mass=1.0, extra=extra) + WIRED)
    plain.write_text(STRING.format(mass=mass, extra=extra))
    probes = ["str[30].position", "str[7].velocity"]
    seconds = 0.2
    compiled = render(load(wired), seconds, probes=probes, engine="compiled")
    python = render(load(wired), seconds, probes=probes, engine="python")
    reference = render(load(plain), seconds, probes=probes, engine="compiled")
    for k in probes:
        np.testing.assert_array_equal(compiled.probes[k], python.probes[k], err_msg=k)
        np.testing.assert_array_equal(compiled.probes[k], reference.probes[k], err_msg=k)
    # and the pitch is the string's of that mass: f1 of a fixed-fixed chain under the half-step scheme
    x = compiled.probes["str[30].position"]
    spectrum = np.abs(np.fft.rfft(x * np.hanning(len(x)), 1 << 20))
    peak = np.fft.rfftfreq(1 << 20, 1.0 / 44100)[np.argmax(spectrum)]
    f1 = float(discrete_frequency(2.0 * math.sqrt(144100.0 / mass) * math.sin(math.pi / (2 * 61)), 44100))
    assert abs(peak - f1) < 0.02 * f1, (peak, f1)
    assert abs(f1 - 254.0) < 1.0


def test_names_are_sanitized_prefixed_and_unique():
    """Issue 12.6: patch text becomes an inert identifier; clashes get _2, _3; reserved words a prefix."""
    from hapticgraph.graph.ir import Names, ident, sanitize
    assert sanitize("x; import os") == "x__import_os"
    assert sanitize("9lives") == "b_9lives" and sanitize("lambda") == "b_lambda" and sanitize("") == "b_"
    assert sanitize("len") == "b_len" and sanitize("state") == "b_state" and sanitize("pâte") == "p_te"
    names = Names(reserved={"delay_output"})
    a, b, c = names.prefix(0, "x;y"), names.prefix(1, "x y"), names.prefix(2, "x_y")
    assert (a, b, c) == ("x_y", "x_y_2", "x_y_3") and names.prefix(0, "x;y") == "x_y"
    assert names.local(("out", 0), "delay", "output") == "delay_output_2"   # a module name is never shadowed
    assert names.local(("s", 1), "x_y", "z") == "x_y_z" and names.local(("s", 2), "x", "y_z") == "x_y_z_2"
    assert names.local(("s", 1), "x_y", "z") == "x_y_z"
    for text in ("x; import os", "os.system('touch PWNED')", "a\nb", "__import__", "\U0001F600" * 50):
        ident(sanitize(text), "name")
    with pytest.raises(KernelSourceError):
        names.local(("bad", 0), "x", "y; import os")
