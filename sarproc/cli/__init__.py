"""Command-line layer: parse, load, call the numerical core, save. Nothing numerical here."""
