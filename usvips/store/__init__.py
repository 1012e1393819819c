"""Where projects are kept: the storage interface (``interface``), its record types and errors
(``records``), the domain checks above every backend (``checks``), the survey's rules over any backend
(``survey``) and the backend interface (``backend``), the opener by location (``opening``), and the two
backends: the SQLite file (``project``) and the PostgreSQL server (``postgres``)."""

from usvips.store.project import SCHEMA_VERSION, Project
from usvips.store.records import ProjectError, StoredObject, Vertex

__all__ = ["SCHEMA_VERSION", "Project", "ProjectError", "StoredObject", "Vertex"]
