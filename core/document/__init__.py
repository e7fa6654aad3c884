"""The document: the project file, its undo history, recovery files and candidate regions."""
