"""``usvips project review PROJECT [--list STATE] [--accept ID …] [--flag ID --reason TEXT]``: the second
reader's review of a project's objects (schema 9). Without an action it prints how many objects are in
each state; ``--list`` prints the objects in one state, one line each (id, kind, attribute, state,
reviewer, when, reason); ``--accept`` and ``--flag`` set states, all in one transaction (all or nothing),
as the annotator (``--annotator``, ``$USVIPS_ANNOTATOR`` or the user name), each kept in the history.
Works on a project file or a survey on a server (any location ``usvips.store.opening.open_project`` takes)."""

from __future__ import annotations

import argparse

from usvips.cli.common import add_annotator_option
from usvips.core.errors import InvalidParameterError

STATES = ("unreviewed", "accepted", "flagged")  # usvips.store.records.REVIEW_STATES (the parser stays light)


def register_review_action(actions: argparse._SubParsersAction) -> None:
    review = actions.add_parser("review", help="review objects as a second reader: list by state, accept, flag "
                                "with a reason")
    review.add_argument("project", help="the project file, or postgresql://USER@HOST[:PORT]/DATABASE")
    review.add_argument("--list", choices=STATES, metavar="STATE", help="list the objects in this state "
                        f"({', '.join(STATES)}), by id")
    review.add_argument("--accept", type=int, nargs="+", metavar="ID", default=[], help="accept these objects")
    review.add_argument("--flag", type=int, metavar="ID", help="flag this object (give --reason)")
    review.add_argument("--reason", metavar="TEXT", help="why the --flag'ged object is wrong (one line)")
    add_annotator_option(review)
    review.set_defaults(handler=run_review)


def run_review(args: argparse.Namespace) -> int:
    args.accept = list(dict.fromkeys(args.accept))  # an id given twice is accepted (and counted) once
    for object_id in [*args.accept, *([args.flag] if args.flag is not None else [])]:
        if object_id < 1:
            raise InvalidParameterError("--accept/--flag", f"an object id is a whole number ≥ 1, got {object_id}")
    if args.flag is not None and args.reason is None:
        raise InvalidParameterError("--flag", "give --reason TEXT: what is wrong with the object")
    if args.reason is not None and args.flag is None:
        raise InvalidParameterError("--reason", "--reason goes with --flag ID")
    if args.flag is not None and args.flag in args.accept:
        raise InvalidParameterError("--flag", f"object {args.flag} is also given to --accept")
    from usvips.store.opening import open_project, shown  # at run time: the parser stays light

    writing = bool(args.accept) or args.flag is not None
    with open_project(args.project, read_only=not writing) as project:
        if writing:
            already = 0  # accepted before (no reason): accepting again writes nothing
            with project.transaction():
                for object_id in args.accept:
                    review = project.review(object_id)
                    already += (review.state, review.reason) == ("accepted", "")
                    project.set_review(object_id, "accepted")
                if args.flag is not None:
                    project.set_review(args.flag, "flagged", args.reason)
            done = [_accepted_text(len(args.accept) - already, already)] if args.accept else []
            done += [f"flagged object {args.flag}"] if args.flag is not None else []
            print(f"{shown(args.project)}: {', '.join(done)} as {project.annotator}")
        if args.list is not None:
            objects = {o.id: o for o in project.objects()}
            for review in project.reviews(args.list):
                stored = objects.get(review.object_id)
                kind, attribute = (stored.kind, stored.attribute) if stored is not None else ("?", "")
                print(f"{review.object_id}\t{kind}\t{attribute}\t{review.state}\t{review.reviewer}\t"
                      f"{review.reviewed}\t{review.reason}")
        elif not writing:
            from usvips.app.project_contents import objects_text, review_counts, reviews_text

            objects, instants, counts = review_counts(project)
            print(f"{shown(args.project)}: {objects_text(objects, instants)}: {reviews_text(counts)}"
                  + (" (each instant reviewed on its own)" if instants else ""))
    return 0


def _accepted_text(newly: int, already: int) -> str:
    """``accepted 2``, ``accepted 1, 1 already accepted``, ``1 already accepted``."""
    parts = [f"accepted {newly}"] if newly else []
    return ", ".join(parts + ([f"{already} already accepted"] if already else []))
