"""``usvips species import PROJECT LIST.csv`` / ``usvips species list PROJECT``: a project's species list
(EventMeasure's and CheckEM's columns family, genus, species, code and optionally a maximum length; see
:mod:`usvips.io.species_list`) — the list the observation form offers and the QA report checks lengths
against. Importing replaces the stored list in one transaction; the file is read and checked first."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("species", help="import or list a project's species list (and maximum lengths)")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    load = actions.add_parser("import", help="replace the project's species list by a CSV file's")
    load.add_argument("project", help="project file (*.usvips) or survey (postgresql://…)")
    load.add_argument("list", help="CSV: family,genus,species[,code][,max_length_mm|cm|m]")
    load.set_defaults(handler=run_import)
    show = actions.add_parser("list", help="print the project's species list")
    show.add_argument("project")
    show.set_defaults(handler=run_list)


def run_import(args: argparse.Namespace) -> int:
    from usvips.io.species_list import read_species_list
    from usvips.store.location import shown
    from usvips.store.opening import open_project

    species = read_species_list(args.list)  # every error names the file and line, before the project opens
    with open_project(args.project) as project:
        project.set_species_list(species)
    maxima = sum(s.max_length_m is not None for s in species)
    print(f"{shown(args.project)}: species list of {len(species)} taxa stored from {args.list}"
          + (f" ({maxima} with a maximum length)" if maxima else " (no maximum lengths)"))
    return 0


def run_list(args: argparse.Namespace) -> int:
    from usvips.store.location import shown
    from usvips.store.opening import open_project

    with open_project(args.project, read_only=True) as project:
        species = project.species_list()
    for s in species:
        maximum = "" if s.max_length_m is None else f"{s.max_length_m * 1000:g} mm"
        print("\t".join((s.family, s.genus, s.species, s.code, maximum)))
    print(f"{shown(args.project)}: {len(species)} taxa")
    return 0
