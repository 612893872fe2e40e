"""Scheduling: a graph of direct-feedthrough dependencies, algebraic loops refused by name, the
rest ordered topologically (ties kept in patch order).

The order comes from the standard library's `graphlib` (networkx costs 0.2 s to import, paid by
every run); only a patch with an algebraic loop imports networkx, to name every loop."""
import graphlib
import heapq


def _edges(blocks, connections):
    """{(u, v): connection} for each edge u → v: v's output in a sample needs u's output of that
    same sample (the first connection that makes the edge)."""
    edges = {}
    for c in connections:
        if c.dst.port in blocks[c.dst.block].cls.feedthrough():
            edges.setdefault((c.src.block, c.dst.block), c)
    return edges


def dependency_graph(blocks, connections):
    """The networkx DiGraph of the dependencies (nodes carry `index`, edges `line` and `text`)."""
    import networkx as nx
    g = nx.DiGraph()
    for name, inst in blocks.items():
        g.add_node(name, index=inst.index)
    for (u, v), c in _edges(blocks, connections).items():
        g.add_edge(u, v, line=c.line, text=str(c))
    return g


def _report_loops(blocks, connections, problems):
    """Add every algebraic loop (a strongly connected component) to `problems`, by name."""
    import networkx as nx
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


def schedule(blocks, connections, problems):
    """Block names in evaluation order; algebraic loops are added to `problems`.

    Among the blocks ready at each step the one first in the patch goes first (the lexicographic
    topological order by patch index)."""
    sorter = graphlib.TopologicalSorter({name: () for name in blocks})
    for u, v in _edges(blocks, connections):
        sorter.add(v, u)
    try:
        sorter.prepare()
    except graphlib.CycleError:
        _report_loops(blocks, connections, problems)
        return []
    ready = [(blocks[n].index, n) for n in sorter.get_ready()]
    heapq.heapify(ready)
    order = []
    while ready:
        _, name = heapq.heappop(ready)
        order.append(name)
        sorter.done(name)
        for n in sorter.get_ready():
            heapq.heappush(ready, (blocks[n].index, n))
    return order
