"""Export: the flat pattern as DXF, SVG, PDF, OBJ and VTK files, behind one registry
(:mod:`flatweave.export.registry`)."""
