"""The patch graph for people: Graphviz dot and Mermaid, one node per block, one edge per
connection (labelled with its ports), links of a fused family (springs) drawn as edges between the points they join;
a block type may declare its `drawing` (a dot shape, mermaid brackets) and `caption`."""
import re


def _id(name):
    return re.sub(r"\W", "_", name)


def _edges(patch):
    """(source block, destination block, label, style) for connections and springs."""
    out = []
    for c in patch.connections:
        src = f"{c.src.port}" if c.src.index is None else f"[{', '.join(map(str, c.src.index))}].{c.src.port}"
        dst = f"{c.dst.port}" if c.dst.index is None else f"[{', '.join(map(str, c.dst.index))}].{c.dst.port}"
        out.append((c.src.block, c.dst.block, f"{src} → {dst}", "signal"))
    for inst in patch.blocks.values():
        family = getattr(inst.cls, "family", None)
        ends = family.link_ends(inst) if family is not None else []
        if len(ends) == 2:          # a link: drawn as an edge between the points it joins
            (a, a_text), (b, b_text) = ends
            out.append((a, inst.name, a_text, "link"))
            out.append((inst.name, b, b_text, "link"))
    return out


def _label(inst):
    extra = inst.cls.caption(inst.values)
    devices = [inst.values[n] for n, p in inst.cls.params.items() if p.refers == "devices" and inst.values.get(n)]
    if not extra and devices:
        extra = f"({devices[0]})"
    extra = f" {extra}" if extra else ""
    return f"{inst.name}\\n{inst.cls.type_name}{extra}"


def to_dot(patch):
    lines = [f"digraph {_id(patch.name) or 'patch'} {{", "  rankdir=LR;",
             '  node [shape=box, style="rounded", fontname="Helvetica", fontsize=10];',
             '  edge [fontname="Helvetica", fontsize=8];']
    for name in patch.order:
        inst = patch.blocks[name]
        shape = getattr(inst.cls, "drawing", {}).get("dot")
        attrs = f'label="{_label(inst)}"' + (f", shape={shape}" if shape else "")
        lines.append(f"  {_id(name)} [{attrs}];")
    for src, dst, label, style in _edges(patch):
        attrs = f'label="{label}"' + (", style=dashed, arrowhead=none" if style == "link" else "")
        lines.append(f"  {_id(src)} -> {_id(dst)} [{attrs}];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def to_mermaid(patch):
    lines = ["flowchart LR"]
    for name in patch.order:
        inst = patch.blocks[name]
        text = _label(inst).replace("\\n", "<br/>")
        left, right = getattr(inst.cls, "drawing", {}).get("mermaid", ("[", "]"))
        lines.append(f'  {_id(name)}{left}"{text}"{right}')
    for src, dst, label, style in _edges(patch):
        arrow = "-.-" if style == "link" else "-->"
        lines.append(f'  {_id(src)} {arrow}|"{label}"| {_id(dst)}')
    return "\n".join(lines) + "\n"
