"""Tour planning around the C++ planner: candidate fields and sites documents, the exact
optimum by integer programming, and the paper's Table I."""
