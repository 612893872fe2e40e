"""The patch graph for people: Graphviz dot and Mermaid, one node per block, one edge per
connection (labelled with its ports), springs drawn as edges between the cells they join."""
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
        if inst.cls.type_name == "spring":
            a, b = inst.values["a"], inst.values["b"]
            out.append((a.split("[")[0].strip(), inst.name, a.strip(), "spring"))
            out.append((inst.name, b.split("[")[0].strip(), b.strip(), "spring"))
    return out


def _label(inst):
    extra = ""
    if inst.cls.type_name == "lattice":
        extra = " " + "×".join(str(s) for s in inst.values["shape"])
    elif inst.cls.params.get("device") is not None and inst.values.get("device"):
        extra = f" ({inst.values['device']})"
    return f"{inst.name}\\n{inst.cls.type_name}{extra}"


def to_dot(patch):
    lines = [f"digraph {_id(patch.name) or 'patch'} {{", "  rankdir=LR;",
             '  node [shape=box, style="rounded", fontname="Helvetica", fontsize=10];',
             '  edge [fontname="Helvetica", fontsize=8];']
    for name in patch.order:
        inst = patch.blocks[name]
        shape = {"lattice": "box3d", "cell": "circle", "spring": "diamond", "haptic": "hexagon",
                 "audio_out": "house"}.get(inst.cls.type_name)
        attrs = f'label="{_label(inst)}"' + (f", shape={shape}" if shape else "")
        lines.append(f"  {_id(name)} [{attrs}];")
    for src, dst, label, style in _edges(patch):
        attrs = f'label="{label}"' + (", style=dashed, arrowhead=none" if style == "spring" else "")
        lines.append(f"  {_id(src)} -> {_id(dst)} [{attrs}];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def to_mermaid(patch):
    lines = ["flowchart LR"]
    for name in patch.order:
        inst = patch.blocks[name]
        text = _label(inst).replace("\\n", "<br/>")
        left, right = {"lattice": ("[[", "]]"), "cell": ("((", "))"), "spring": ("{", "}"),
                       "haptic": ("{{", "}}")}.get(inst.cls.type_name, ("[", "]"))
        lines.append(f'  {_id(name)}{left}"{text}"{right}')
    for src, dst, label, style in _edges(patch):
        arrow = "-.-" if style == "spring" else "-->"
        lines.append(f'  {_id(src)} {arrow}|"{label}"| {_id(dst)}')
    return "\n".join(lines) + "\n"
