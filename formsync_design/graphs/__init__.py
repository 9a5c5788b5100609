"""Stage 1 — communication graphs: specs, files, networkx/numpy inputs, Laplacians;
weighted digraphs with leader pinning and the properties a design's theorem requires."""

from formsync_design.graphs.build import GRAPH_SPEC_HELP, Graph, make_graph, parse_graph_spec
from formsync_design.graphs.digraph import Digraph, GraphProperty
from formsync_design.graphs.digraph_io import make_digraph
from formsync_design.graphs.theorem import TheoremCheck, check_theorem_graph, load_graph

__all__ = [
    "Graph",
    "make_graph",
    "parse_graph_spec",
    "GRAPH_SPEC_HELP",
    "Digraph",
    "GraphProperty",
    "make_digraph",
    "TheoremCheck",
    "check_theorem_graph",
    "load_graph",
]
