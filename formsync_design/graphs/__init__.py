"""Stage 1 — communication graphs: specs, files, networkx/numpy inputs, Laplacians."""

from formsync_design.graphs.build import GRAPH_SPEC_HELP, Graph, make_graph, parse_graph_spec

__all__ = ["Graph", "make_graph", "parse_graph_spec", "GRAPH_SPEC_HELP"]
