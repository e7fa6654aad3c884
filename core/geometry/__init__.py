"""Geometry: NURBS surfaces, curves on them, regions of their domain, quadrature, coverage,
and the fit of a triangle mesh by a surface. Knows nothing of fabric."""
