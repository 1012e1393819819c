"""The project database: one SQLite file per project (``*.usvips``), standard-library sqlite3."""

from usvips.store.project import SCHEMA_VERSION, Project, ProjectError

__all__ = ["SCHEMA_VERSION", "Project", "ProjectError"]
