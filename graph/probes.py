"""Probes: `BLOCK.PORT` (an output, an input, a live parameter or a state) or `NAME[i, j].PORT`
(a point of a fused group: for a lattice, a cell's position, velocity, or force — the sum of the
forces wired into it), resolved to the IR node the kernel records."""
import re

from .errors import PlanError, name_list, suggest
from .ir import Total
from .model import Endpoint

_BARE = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*(\[[^\]]*\])?\s*")   # a block (or cell) without `.PORT`


def resolve_probe(prog, probe):
    """The IR node probe `probe` records; PlanError naming the probe if it names nothing."""
    end = Endpoint.parse(probe)
    if end is None:
        raise PlanError(f"probe {probe!r}: {_bare_problem(prog, probe) or Endpoint.problem(probe)}")
    bp = prog.by_name.get(end.block)
    if bp is None:
        names = list(prog.by_name)
        raise PlanError(f"probe {probe!r}: no block named {end.block!r}{suggest(end.block, names)}; "
                        f"its blocks: {name_list(names)}")
    gs = prog.group_of.get(end.block)
    if gs is not None and (end.index is not None or end.port in gs.family.point_ports):
        return _point(prog, gs, bp, end, probe)
    if end.index is not None:
        raise PlanError(f"probe {probe!r}: block {end.block!r} ({bp.cls.type_name}) has no cells to index")
    return _port(prog, bp, end, probe)


def _point(prog, gs, bp, end, probe):
    ports = gs.family.point_ports
    message = None
    if end.index is not None or gs.point(end) is None:
        if end.index is None:
            message = f"{end.block!r} has many points; address one as {end.block}[i, ...].{end.port}"
        else:
            message = gs.family.point_problem(bp.inst, end.index, end.port, "probe")
    elif end.port not in ports:
        message = f"a point has no port {end.port!r}; its ports: {', '.join(ports)}"
    if message is None and gs.point(end) is None:
        message = f"{end.block}{list(end.index)} is not a point of its group"
    if message:
        raise PlanError(f"probe {probe!r}: {message}")
    if ports[end.port] == "input" and bp.inst.output(end.port) is None:
        return gs.driven(end)
    return Total((gs.element(end),))


def _port(prog, bp, end, probe):
    block, port = end.block, end.port
    if bp.inst.output(port) is not None:
        return Total((prog.source(Endpoint(block, None, port)),))
    for p in bp.inst.inputs:
        if p.name == port:
            return Total(bp.inputs.get(port, ()))
    if port in bp.cls.params and bp.cls.params[port].live:
        return prog.param_binding(bp, port)
    for i, s in enumerate(bp.cls.states):
        if s.attr == port:
            return bp.state_nodes[i]
    names = _probe_names(bp)
    raise PlanError(f"probe {probe!r}: block {block!r} ({bp.cls.type_name}) has no port or state "
                    f"{port!r}{suggest(port, names)}; it has: {', '.join(names) or 'none'}")


def _probe_names(bp):
    """What a probe of block plan `bp` can name: outputs, inputs, live parameters, states."""
    return list(dict.fromkeys([p.name for p in bp.inst.outputs + bp.inst.inputs]
                              + [n for n, p in bp.cls.params.items() if p.live] + [s.attr for s in bp.cls.states]))


def _bare_problem(prog, probe):
    """What to say of a probe naming a block (or a cell) without a port: the block's ports, or the
    block names with a did-you-mean; None if it is not such a probe."""
    m = _BARE.fullmatch(probe)
    if m is None:
        return None
    block, index = m.groups()
    bp = prog.by_name.get(block)
    if bp is None:
        return (f"no block named {block!r}{suggest(block, prog.by_name)}; its blocks: {name_list(prog.by_name)} "
                f"(a probe is written BLOCK.PORT)")
    gs = prog.group_of.get(block)
    if gs is not None and (index is not None or gs.family.point_ports):
        ports = ", ".join(gs.family.point_ports)
        return f"a probe names a port: write {block}{index or '[i, ...]'}.PORT; its points have: {ports}"
    return (f"a probe names a port: write {block}.PORT; block {block!r} ({bp.cls.type_name}) has: "
            f"{', '.join(_probe_names(bp)) or 'none'}")
