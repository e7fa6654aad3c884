"""The method: the spring lattice, its drape on the surface, the energy and its solvers,
darts, the flat pattern, metrics and their judgement, and the pipeline that runs them."""
