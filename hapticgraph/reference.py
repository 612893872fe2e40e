"""The block reference, generated from the block declarations (never from prose)."""
from .graph.registry import Registry

# the two papers the built-in blocks implement, as "Ref:" lines cite them (short form -> full)
PAPERS = {
    "Berdahl et al. 2009": "Edgar Berdahl, Günter Niemeyer and Julius O. Smith III, \"Using Haptic Devices "
                           "to Interface Directly with Digital Waveguide-Based Musical Instruments\", "
                           "Proceedings of the International Conference on New Interfaces for Musical "
                           "Expression (NIME 2009), Pittsburgh, PA, USA, pp. 183–186.",
    "Howard & Rimell 2003": "David M. Howard and Stuart M. Rimell, \"Cymatic: a Tactile Controlled Physical "
                            "Modelling Instrument\", Proceedings of the 6th International Conference on "
                            "Digital Audio Effects (DAFx-03), London, UK, 2003.",
}

HEADER = """# Block reference

Generated from the block declarations by `hapticgraph blocks --markdown > docs/blocks.md`;
a test keeps it current. Ports are `inputs -> outputs`; a live parameter (marked *live*) is also
an input port. Units are SI. The "Ref:" of each equation cites:

""" + "".join(f"- **{short}**: {full}\n" for short, full in PAPERS.items())


def _range(p):
    parts = []
    if p.minimum is not None:
        parts.append(f"≥ {p.minimum:g}")
    if p.above is not None:
        parts.append(f"> {p.above:g}")
    if p.maximum is not None:
        parts.append(f"≤ {p.maximum:g}")
    if p.below is not None:
        parts.append(f"< {p.below:g}")
    if p.choices:
        parts.append(" \\| ".join(f"`{c}`" for c in p.choices))
    return ", ".join(parts)


def _default(p):
    if p.kind == "list":
        return "[" + ", ".join(f"{v:g}" for v in p.default) + "]"
    if p.kind == "data":
        return f"`{p.default!r}`"
    if isinstance(p.default, str):
        return f"`{p.default!r}`" if p.default else "—"
    return f"`{p.default!r}`"


def block_reference(registry=None):
    registry = registry or Registry(entry_points=False)
    out = [HEADER]
    names = sorted(registry.types)
    out.append(" · ".join(f"[`{n}`](#{n})" for n in names) + "\n")
    for name in names:
        cls = registry.types[name]
        inputs, outputs = cls.ports(cls.default_params())
        doc = (cls.__doc__ or "").strip().splitlines()
        out.append(f"## {name}\n")
        if doc:
            out.append(doc[0] + "\n")
        if cls.notes:
            out.append(cls.notes.strip() + "\n")
        ins = [p.name for p in inputs] + [f"{n}*" for n, p in cls.params.items() if p.live]
        ports = f"`{', '.join(ins) or '—'} -> {', '.join(p.name for p in outputs) or '—'}`"
        if getattr(cls, "check_cell", None) is not None:
            ports += "; each cell `name[i, ...]` has `force -> position, velocity`"
        if "axes" in cls.params:
            ports += "; plus one output per axis or button of its device"
        out.append(f"Ports: {ports}. Feeds through: {', '.join(sorted(cls.feedthrough())) or 'nothing'}.\n")
        params = [(n, p) for n, p in cls.params.items() if not p.internal]
        if params:
            out.append("| parameter | default | unit | range | live | meaning |")
            out.append("|---|---|---|---|---|---|")
            for n, p in params:
                out.append(f"| `{n}` | {_default(p)} | {p.unit} | {_range(p)} | {'yes' if p.live else ''} | "
                           f"{p.doc.replace('|', '/')} |")
            out.append("")
    return "\n".join(out).rstrip() + "\n"
