"""Studies over many solves: the orientation sweep, suggested darts, and the planar
comparison method."""
