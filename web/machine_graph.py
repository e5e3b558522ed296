"""A state machine drawn as a graph (networkx lays it out, matplotlib draws it): states in
layers by their distance from the start, transitions coloured by autonomy level, the current
state filled, a pending decision's target ringed. An image for viser's GUI (RGB array)."""

from typing import Any

import matplotlib

matplotlib.use("Agg")  # files and arrays only: the console runs headless
import matplotlib.pyplot as plt
import networkx as nx
import numpy as np

from robot_sim.machines.spec import AUTONOMY_LEVELS, TERMINALS, MachineSpec

LEVEL_COLOURS = {"off": "#9ca3af", "low": "#2563eb", "high": "#ea580c", "full": "#dc2626"}
TERMINAL_COLOURS = {"completed": "#bbf7d0", "failed": "#fecaca"}
CURRENT = "#facc15"


def machine_graph(spec: MachineSpec) -> "nx.MultiDiGraph[str]":
    """States and terminals as nodes (`layer`: hops from the start), transitions as edges."""
    graph: nx.MultiDiGraph[str] = nx.MultiDiGraph()
    graph.add_nodes_from(spec.states)
    graph.add_nodes_from(TERMINALS)
    for source, target, label, level in spec.edges():
        graph.add_edge(source, target, label=label, level=level)
    hops = nx.single_source_shortest_path_length(graph, spec.start)
    deepest = max(hops.values(), default=0)
    for node in graph.nodes:
        graph.nodes[node]["layer"] = deepest + 1 if node in TERMINALS else hops.get(node, deepest + 1)
    return graph


def draw_machine(
    spec: MachineSpec, current: str | None = None, pending: str | None = None, width_px: int = 460
) -> np.ndarray:
    """The graph as an RGB image: `current` filled, `pending` (a decision's target) ringed."""
    graph = machine_graph(spec)
    places = nx.multipartite_layout(graph, subset_key="layer", align="horizontal", scale=1.0)
    places = {node: (x, -y) for node, (x, y) in ((n, (p[0], p[1])) for n, p in places.items())}
    layers = 1 + max(graph.nodes[n]["layer"] for n in graph.nodes)
    fig, ax = plt.subplots(figsize=(width_px / 100.0, max(2.4, 0.62 * layers)), dpi=100)
    colours = [CURRENT if node == current else TERMINAL_COLOURS.get(node, "#e5e7eb") for node in graph.nodes]
    nx.draw_networkx_nodes(graph, places, ax=ax, node_color=colours, node_size=650, edgecolors="#374151")
    if pending is not None and pending in graph:
        nx.draw_networkx_nodes(
            graph,
            places,
            nodelist=[pending],
            ax=ax,
            node_color="none",
            node_size=1000,
            edgecolors=CURRENT,
            linewidths=3.0,
        )
    for level in AUTONOMY_LEVELS:
        edges = [(u, v, k) for u, v, k, d in graph.edges(keys=True, data=True) if d["level"] == level]
        nx.draw_networkx_edges(
            graph,
            places,
            edgelist=edges,
            ax=ax,
            edge_color=LEVEL_COLOURS[level],
            arrows=True,
            arrowsize=12,
            node_size=650,
            connectionstyle="arc3,rad=0.15",
            width=2.2 if level in ("high", "full") else 1.3,
        )
    nx.draw_networkx_labels(graph, places, ax=ax, font_size=7)
    handles = [plt.Line2D([], [], color=LEVEL_COLOURS[lv], label=lv) for lv in AUTONOMY_LEVELS]
    ax.legend(handles=handles, title="transition level", fontsize=6, title_fontsize=6, loc="lower left")
    ax.set_axis_off()
    fig.tight_layout(pad=0.2)
    fig.canvas.draw()
    image = np.array(fig.canvas.buffer_rgba())[..., :3]  # type: ignore[attr-defined]
    plt.close(fig)
    return image


def graph_key(spec: MachineSpec | None, machine: dict[str, Any] | None) -> tuple[Any, ...]:
    """What the drawing depends on: the machine and, while it runs, its state and pending target."""
    pending = (machine or {}).get("pending") or {}
    return (
        spec.model_dump_json() if spec is not None else None,
        (machine or {}).get("state"),
        pending.get("target"),
    )
