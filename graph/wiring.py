"""Connections: `block.port -> block.port` (a point of a fused group as `name[i, j].port`), each
end checked against the block's ports, live parameters and points, with a FILE:LINE problem
naming the block and port at fault."""
from .errors import suggest
from .model import Connection, Endpoint
from .source import LDict, LList


def connections_of(doc, blocks, problems):
    """The patch's connections (Connection), each end checked; problems reported at their lines."""
    conns = doc.get("connect")
    out = []
    if not isinstance(conns, LList):
        return out
    names = doc.get("blocks") if isinstance(doc.get("blocks"), LDict) else {}
    for text, line in zip(conns, conns.lines):
        if problems.full:
            break
        if not isinstance(text, str) or "->" not in text:
            continue  # reported by the schema
        left, _, right = text.partition("->")
        src, dst = Endpoint.parse(left), Endpoint.parse(right)
        if src is None or dst is None:
            continue  # reported by the schema (its pattern), with the reason
        ok = True
        for end, role in ((src, "output"), (dst, "input")):
            if end.block not in names:
                problems.add(line, f"connection {text.strip()!r}: no block named {end.block!r}"
                                   f"{suggest(end.block, names)}")
                ok = False
                continue
            inst = blocks.get(end.block)
            if inst is None:
                ok = False  # the block itself has a problem, reported already
                continue
            if not _check_endpoint(inst, end, role, text.strip(), line, problems):
                ok = False
        if ok:
            out.append(Connection(src, dst, line))
    return out


def _check_endpoint(inst, end, role, text, line, problems):
    cls = inst.cls
    family = getattr(cls, "family", None)
    if end.index is not None:
        where = f"{inst.name}[{', '.join(map(str, end.index))}]"
        if family is None:
            problems.add(line, f"connection {text!r}: block {inst.name!r} ({cls.type_name}) has no cells "
                               f"to index with [{', '.join(map(str, end.index))}]")
            return False
        message = family.point_problem(inst, end.index, end.port, role)
        if message:
            problems.add(line, f"connection {text!r}: {where}: {message}")
            return False
        return True
    found = inst.output(end.port) if role == "output" else inst.input(end.port)
    if found is not None:
        return True
    if family is not None and end.port in family.point_ports:
        problems.add(line, f"connection {text!r}: {inst.name!r} is a {cls.type_name}; address one of its cells "
                           f"as {inst.name}[i, ...].{end.port}")
        return False
    other = inst.input(end.port) if role == "output" else inst.output(end.port)
    ports = [p.name for p in (inst.outputs if role == "output" else inst.inputs)]
    if role == "input":
        ports += [n for n, p in cls.params.items() if p.live]
    if other is not None:
        msg = f"{end.port!r} of block {inst.name!r} ({cls.type_name}) is an {'input' if role == 'output' else 'output'}, " \
              f"it cannot be the {'source' if role == 'output' else 'destination'} of a connection"
    elif role == "input" and end.port in cls.params:
        msg = f"parameter {end.port!r} of block {inst.name!r} ({cls.type_name}) is not live, so it is not an input"
    else:
        msg = (f"block {inst.name!r} ({cls.type_name}) has no {role} {end.port!r}"
               f"{suggest(end.port, ports)}; its {role}s: {', '.join(ports) or 'none'}")
    problems.add(line, f"connection {text!r}: {msg}")
    return False
