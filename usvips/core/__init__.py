"""Pure computation: camera model, refraction, intersection, adjustment. No Qt, no SQLite, no files."""
