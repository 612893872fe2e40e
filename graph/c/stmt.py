"""Python statements in C: one function's body, translated until the types of its variables
settle (a variable assigned an integer and later a double is a double from the start, as numba
types it). What a `return` or a `yield` means is the mode's (a per-sample function returns its
values; a block's `derive` writes coefficients: graph/c/setup.py)."""
import ast

from . import ops
from .expr import ExprTranslator, cname
from .values import ARRAYS, C_TYPES, NUMBER_ARRAYS, Val, join, known, text


def assigned_names(nodes):
    return {n.id for node in nodes for n in ast.walk(node) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)}


def ends_in_return(body):
    """Whether every path through `body` ends with a return (or runs forever)."""
    if not body:
        return False
    last = body[-1]
    if isinstance(last, (ast.Return, ast.Raise)):
        return True
    if isinstance(last, ast.If):
        return ends_in_return(last.body) and ends_in_return(last.orelse)
    if isinstance(last, ast.While):
        return isinstance(last.test, ast.Constant) and last.test.value is True
    return False


class FunctionTranslator(ExprTranslator):
    """One function's C body. `params`: [(name, Val)] (a known value is bound, the others are C
    parameters); `mode` says what `return`, `yield` and the end of the body become."""

    unroll_inner = True      # an innermost range loop is marked HG_UNROLL (not the kernel's sample loop)

    def __init__(self, lib, node, file, names, params, mode):
        super().__init__(lib, file, names)
        self.node, self.params, self.mode = node, params, mode
        self.counts = {}
        for n in ast.walk(node):
            if isinstance(n, ast.Name):
                self.counts[n.id] = self.counts.get(n.id, 0) + 1

    def translate(self):
        """(declarations, body lines) of the function; Refused at the first thing not translated."""
        for _ in range(8):
            self.env, self.cvars, self.lines, self.level, self.depth = {}, set(), [], 1, 0
            self.dirty, self.temps, self.internal = False, 0, set()
            for name, value in self.params:
                if value.is_known or value.kind == "params":
                    self.env[name] = value
                else:
                    self.seed.setdefault(name, [value.kind, value.nonneg])
                    self.cvars.add(name)
            body = self.node.body if isinstance(self.node.body, list) else [ast.Return(self.node.body)]
            if isinstance(self.node.body, list):
                self.block(body)
            else:
                ast.copy_location(body[0], self.node.body)
                self.statement(body[0])
            self.mode.end(self)
            if not self.dirty:
                return self.declarations(), self.lines
        self.refuse("the types of its variables do not settle", self.node)

    def declarations(self):
        """`T name;` of every local (and a parameter widened: `T name = name_in;`)."""
        given = {name: value for name, value in self.params}
        out = []
        for name in sorted(self.cvars, key=lambda n: (n in self.internal, n)):
            kind = self.seed[name][0]
            if name in given:
                if kind != given[name].kind:
                    out.append(f"{C_TYPES[kind]} {cname(name)} = {self.param_name(name)};")
                continue
            out.append(f"{C_TYPES[kind]} {name if name in self.internal else cname(name)};")
        return out

    def param_name(self, name):
        """A C parameter's name: the variable's, or `hg_in_NAME` when the body widens its type."""
        given = dict(self.params)[name]
        return cname(name) if self.seed.get(name, [given.kind])[0] == given.kind else f"hg_in_{name}"

    # -- emitting ---------------------------------------------------------------------------------
    def emit(self, line):
        self.lines.append("    " * self.level + line)

    def declare(self, name, kind, nonneg):
        """`name` is a C variable of (at least) this type from here on."""
        if kind not in C_TYPES:
            self.refuse(f"{name!r} would hold a {kind!r} value")
        old = self.seed.get(name)
        if old is None:
            self.seed[name] = [kind, nonneg]
        else:
            new = [join(old[0], kind), old[1] and nonneg]
            if new[0] is None:
                self.refuse(f"{name!r} holds both a {old[0]!r} and a {kind!r} value")
            if new != old:
                self.seed[name], self.dirty = new, True
        self.env.pop(name, None)
        self.cvars.add(name)

    def fresh(self, kind, nonneg=False):
        self.temps += 1
        name = f"hg_t{self.temps}"
        self.internal.add(name)
        self.declare(name, kind, nonneg)
        return name

    def temp(self, value):
        name = self.fresh(value.kind, value.nonneg)
        self.emit(f"{name} = {text(value) if value.scalar else value.c};")
        return Val(value.kind, name, nonneg=value.nonneg)

    def materialize(self, nodes):
        """Names bound to known values and assigned in `nodes` (a branch, a loop) become C variables first."""
        for name in sorted(assigned_names(nodes)):
            value = self.env.get(name)
            if value is None or value.kind == "params":
                continue
            if not value.scalar:
                self.refuse(f"{name!r} holds a {type(value.known).__name__} and is assigned again in a branch or loop")
            self.declare(name, value.kind, value.nonneg)
            self.emit(f"{cname(name)} = {text(value)};")

    # -- statements -------------------------------------------------------------------------------
    def block(self, body):
        """The statements of `body`; True when it certainly ends there (a return, a break: what
        follows in Python is never run, so it is not written)."""
        for node in body:
            if self.statement(node):
                return True
        return False

    def statement(self, node):
        self.line = node.lineno
        method = _STATEMENTS.get(type(node))
        if method is None:
            self.refuse(f"the statement {type(node).__name__} ({ast.unparse(node).splitlines()[0][:60]})", node)
        return bool(method(self, node))

    def s_assign(self, node):
        if len(node.targets) != 1:
            self.refuse("a chained assignment", node)
        target = node.targets[0]
        if isinstance(target, ast.Tuple):
            return self.assign_tuple(target.elts, node.value)
        self.store(target, self.expr(node.value))

    def s_augassign(self, node):
        load = ast.copy_location(type(node.target)(**{**vars(node.target), "ctx": ast.Load()}), node.target)
        try:
            value = ops.binop(node.op, self.expr(load), self.expr(node.value))
        except ValueError as exc:
            self.refuse(str(exc), node)
        self.store(node.target, value)

    def store(self, target, value):
        if value.kind in ("none", "multi", "tuple") or (value.is_known and not value.scalar and self.depth):
            self.refuse(f"assigning a {value.kind!r} value", target)
        if isinstance(target, ast.Name):
            name = target.id
            if value.is_known and self.depth == 0 and name not in self.cvars:
                self.env[name] = value
                return
            if not value.scalar and value.kind not in ARRAYS and value.kind != "fp":
                self.refuse(f"{name!r} assigned a {value.kind!r} value", target)
            self.declare(name, value.kind, value.nonneg)
            self.emit(f"{cname(name)} = {text(value) if value.scalar else value.c};")
        elif isinstance(target, ast.Subscript):
            base = self.expr(target.value)
            if base.kind not in NUMBER_ARRAYS and base.kind != "rec":
                self.refuse(f"writing into a {base.kind!r} value", target)
            place = self.expr(ast.copy_location(ast.Subscript(target.value, target.slice, ast.Load()), target))
            if not value.scalar:
                self.refuse("an array element assigned a non-number", target)
            self.emit(f"{place.c} = {text(value)};")
        else:
            self.refuse(f"assigning to {ast.unparse(target)}", target)

    def assign_tuple(self, targets, value_node):
        value = self.expr(value_node)
        if value.kind == "multi":
            return self.unpack_call(targets, value)
        items = value.items if value.kind == "tuple" else (
            tuple(known(v) for v in value.known) if value.is_known and isinstance(value.known, tuple) else None)
        if items is None or len(items) != len(targets):
            self.refuse("unpacking something that is not a tuple of as many values", value_node)
        if len(targets) > 1 and not all(i.is_known for i in items):
            items = tuple(i if i.is_known else self.temp(i) for i in items)
        for t, v in zip(targets, items):
            self.store(t, v)

    def unpack_call(self, targets, value):
        args, kinds = value.items
        if len(kinds) != len(targets):
            self.refuse(f"unpacking {len(kinds)} values into {len(targets)} names", targets[0])
        outs, after = [], []
        for t, kind in zip(targets, kinds):
            if isinstance(t, ast.Name) and t.id != "_":
                self.declare(t.id, kind, False)
                if self.seed[t.id][0] == kind:
                    outs.append(f"&{cname(t.id)}")
                    continue
            name = self.fresh(kind)
            outs.append(f"&{name}")
            if not (isinstance(t, ast.Name) and t.id == "_"):
                after.append((t, Val(kind, name)))
        self.emit(f"{value.c}({', '.join(list(args) + outs)});")
        for t, v in after:
            self.store(t, v)

    def s_if(self, node):
        test = self.expr(node.test)
        if test.is_known:
            return self.block(node.body if test.known else node.orelse)
        self.materialize(node.body + node.orelse)
        self.emit(f"if ({ops.condition(test)}) {{")
        self.inside(node.body)
        if node.orelse:
            self.emit("} else {")
            self.inside(node.orelse)
        self.emit("}")

    def inside(self, body):
        self.level, self.depth = self.level + 1, self.depth + 1
        self.block(body)
        self.level, self.depth = self.level - 1, self.depth - 1

    def s_for(self, node):
        it = node.iter
        ranged = isinstance(it, ast.Call) and isinstance(it.func, ast.Name) and it.func.id == "range"
        over = None if ranged else self.evaluate(it)
        if over is not None and not node.orelse:
            return self.unroll(node, over.known)
        if node.orelse or not isinstance(node.target, ast.Name) or not (
                isinstance(it, ast.Call) and isinstance(it.func, ast.Name) and it.func.id == "range"
                and self.lookup("range", it).known is ops.BUILTINS["range"] and not it.keywords):
            self.refuse("a for loop other than `for NAME in range(...)` without else", node)
        args = [self.expr(a) for a in it.args]
        if not 1 <= len(args) <= 3 or any(a.kind not in ("i", "b") for a in args):
            self.refuse("range() of integers", node)
        start, stop, step = (args + [Val("i", known=1, nonneg=True)])[:3] if len(args) > 1 else (
            Val("i", known=0, nonneg=True), args[0], Val("i", known=1, nonneg=True))
        if not step.is_known or step.known == 0:
            self.refuse("range() with a step known only while running", node)
        var = node.target.id
        self.materialize(node.body + [node.target])
        body_names = assigned_names(node.body)
        if not stop.is_known and not (stop.c.isidentifier() and stop.c not in body_names):
            stop = self.temp(stop)
        inside = sum(1 for n in ast.walk(node) if isinstance(n, ast.Name) and n.id == var)
        direct = var not in body_names and inside == self.counts.get(var, 0)
        counter = cname(var) if direct else self.fresh("i", start.nonneg and step.known > 0)
        self.declare(var, "i", start.nonneg and step.known > 0)
        less = "<" if step.known > 0 else ">"
        if self.unroll_inner and not any(isinstance(n, (ast.For, ast.While)) for b in node.body for n in ast.walk(b)):
            self.emit("HG_UNROLL")
        self.emit(f"for ({counter} = {text(start)}; {counter} {less} {text(stop)}; {counter} += {text(step)}) {{")
        if not direct:
            self.emit(f"    {cname(var)} = {counter};")
        self.inside(node.body)
        self.emit("}")

    def unroll(self, node, items):
        """`for` over a value known while translating (a parameter's list, a tuple of pairs): the
        body once per item, the target bound to it."""
        if any(isinstance(n, (ast.Break, ast.Continue)) for n in ast.walk(node)):
            self.refuse("break or continue in a loop over a known list", node)
        try:
            items = list(items)
        except TypeError:
            self.refuse("a for loop over something that is not iterable", node)
        if len(items) > 4096:
            self.refuse("a loop over more than 4096 known items", node)
        targets = node.target.elts if isinstance(node.target, ast.Tuple) else [node.target]
        for item in items:
            values = list(item) if len(targets) > 1 else [item]
            if len(values) != len(targets) or not all(isinstance(t, ast.Name) for t in targets):
                self.refuse("unpacking a known item into names", node)
            for t, v in zip(targets, values):
                self.env[t.id] = known(v)
            if self.block(node.body):
                return True
        return False

    def s_while(self, node):
        if node.orelse:
            self.refuse("while ... else", node)
        self.materialize(node.body)
        test = self.expr(node.test)
        if test.is_known and not test.known:
            return
        self.emit(f"while ({ops.condition(test)}) {{")
        self.inside(node.body)
        self.emit("}")

    def s_expr(self, node):
        if isinstance(node.value, ast.Constant):
            return                                   # a docstring
        if isinstance(node.value, (ast.Yield, ast.YieldFrom)):
            return self.mode.on_yield(self, node.value)
        value = self.expr(node.value)
        if value.kind == "multi":
            args, kinds = value.items
            self.emit(f"{value.c}({', '.join(list(args) + ['&' + self.fresh(k) for k in kinds])});")
        elif not value.is_known:
            self.emit(f"{value.c};" if value.kind == "none" else f"(void){value.c};")

    def s_return(self, node):
        self.mode.on_return(self, node)
        return True

    def s_break(self, node):
        self.emit("break;")
        return True

    def s_continue(self, node):
        self.emit("continue;")
        return True

    def s_pass(self, node):
        pass


_STATEMENTS = {ast.Assign: FunctionTranslator.s_assign, ast.AugAssign: FunctionTranslator.s_augassign,
               ast.If: FunctionTranslator.s_if, ast.For: FunctionTranslator.s_for,
               ast.While: FunctionTranslator.s_while, ast.Expr: FunctionTranslator.s_expr,
               ast.Return: FunctionTranslator.s_return, ast.Break: FunctionTranslator.s_break,
               ast.Continue: FunctionTranslator.s_continue, ast.Pass: FunctionTranslator.s_pass}

__all__ = ["FunctionTranslator", "assigned_names", "ends_in_return"]
