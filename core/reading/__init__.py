"""Reading: every input file format (surface JSON, STEP/IGES, meshes, projects, the bundled
examples) behind one registry, and what a file opened as (:class:`Opened`)."""
