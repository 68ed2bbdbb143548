"""The dataflow IR: nodes, Q-formats, graph, verifier and interpreters."""
