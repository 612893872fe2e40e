"""Scheduling: a networkx graph of direct-feedthrough dependencies, algebraic loops refused by
name, the rest ordered topologically (ties kept in patch order)."""
import networkx as nx


def dependency_graph(blocks, connections):
    """Edge u → v when v's output in a sample needs u's output of that same sample."""
    g = nx.DiGraph()
    for name, inst in blocks.items():
        g.add_node(name, index=inst.index)
    for c in connections:
        dst = blocks[c.dst.block]
        if c.dst.port in dst.cls.feedthrough():
            if not g.has_edge(c.src.block, c.dst.block):
                g.add_edge(c.src.block, c.dst.block, line=c.line, text=str(c))
    return g


def schedule(blocks, connections, problems):
    """Block names in evaluation order; algebraic loops are added to `problems`."""
    g = dependency_graph(blocks, connections)
    loops = [scc for scc in nx.strongly_connected_components(g)
             if len(scc) > 1 or any(g.has_edge(n, n) for n in scc)]
    for scc in sorted(loops, key=lambda s: min(blocks[n].index for n in s)):
        cycle = nx.find_cycle(g.subgraph(scc))
        names = [u for u, _ in cycle] + [cycle[0][0]]
        line = min(g.edges[u, v]["line"] for u, v in cycle)
        problems.add(line, "algebraic loop: " + " -> ".join(names)
                     + ": each of these blocks feeds its input straight through to its output in the same "
                       "sample; put a delay (or another block with state) on the loop")
    if loops:
        return []
    return list(nx.lexicographical_topological_sort(g, key=lambda n: blocks[n].index))
