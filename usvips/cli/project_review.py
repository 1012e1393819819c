"""``usvips project review PROJECT [--list STATE] [--accept ID …] [--flag ID --reason TEXT]``: the second
reader's review of a project's objects (schema 9). Without an action it prints how many objects are in
each state; ``--list`` prints the objects in one state, one line each (id, kind, attribute, state,
reviewer, when, reason, and last the object's version); ``--accept`` and ``--flag`` set states, all in one
transaction (all or nothing); an id given as ``ID@VERSION`` (the version ``--list`` printed) is refused by
name when someone changed the object since (nothing is written),
as the annotator (``--annotator``, ``$USVIPS_ANNOTATOR`` or the user name), each kept in the history.
Works on a project file or a survey on a server (any location ``usvips.store.opening.open_project`` takes)."""

from __future__ import annotations

import argparse
from datetime import datetime

from usvips.cli.common import add_annotator_option
from usvips.core.errors import InvalidParameterError

STATES = ("unreviewed", "accepted", "flagged")  # usvips.store.records.REVIEW_STATES (the parser stays light)


def register_review_action(actions: argparse._SubParsersAction) -> None:
    review = actions.add_parser("review", help="review objects as a second reader: list by state, accept, flag "
                                "with a reason")
    review.add_argument("project", help="the project file, or postgresql://USER@HOST[:PORT]/DATABASE")
    review.add_argument("--list", choices=STATES, metavar="STATE", help="list the objects in this state "
                        f"({', '.join(STATES)}), by id")
    review.add_argument("--accept", type=_object_version, nargs="+", metavar="ID[@VERSION]", default=[],
                        help="accept these objects; ID@VERSION (the last column of --list): refused when the "
                        "object changed since you listed it")
    review.add_argument("--flag", type=_object_version, metavar="ID[@VERSION]",
                        help="flag this object (give --reason); ID@VERSION as for --accept")
    review.add_argument("--reason", metavar="TEXT", help="why the --flag'ged object is wrong (one line)")
    add_annotator_option(review)
    review.set_defaults(handler=run_review)


def _object_version(text: str) -> tuple[int, str | None]:
    """``ID`` or ``ID@VERSION`` (the object's ``modified`` stamp as ``--list`` printed it)."""
    number, _, version = text.partition("@")
    try:
        object_id = int(number)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an object id (ID or ID@VERSION)") from None
    if version:
        try:
            datetime.fromisoformat(version)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{text!r}: {version!r} is not a version stamp; VERSION is the object's last change as the last "
                "column of --list prints it (a date and time such as 2026-03-01T10:15:00.123456+00:00)") from None
    return object_id, (version or None)


def run_review(args: argparse.Namespace) -> int:
    versions = {object_id: version for object_id, version in [*args.accept, *([args.flag] if args.flag else [])]}
    args.accept = list(dict.fromkeys(object_id for object_id, _ in args.accept))  # an id given twice counts once
    args.flag = args.flag[0] if args.flag is not None else None
    for object_id in [*args.accept, *([args.flag] if args.flag is not None else [])]:
        if object_id < 1:
            raise InvalidParameterError("--accept/--flag", f"an object id is a whole number ≥ 1, got {object_id}")
    if args.flag is not None and args.reason is None:
        raise InvalidParameterError("--flag", "give --reason TEXT: what is wrong with the object")
    if args.reason is not None and args.flag is None:
        raise InvalidParameterError("--reason", "--reason goes with --flag ID")
    if args.flag is not None and args.flag in args.accept:
        raise InvalidParameterError("--flag", f"object {args.flag} is also given to --accept")
    from usvips.store.location import shown  # at run time: the parser stays light
    from usvips.store.opening import open_project

    writing = bool(args.accept) or args.flag is not None
    with open_project(args.project, read_only=not writing) as project:
        if writing:
            already = 0  # accepted before (no reason): accepting again writes nothing
            overturned: list[str] = []  # another reviewer's verdict replaced: said, with theirs
            with project.transaction():
                for object_id in args.accept:
                    review = project.review(object_id)
                    already += (review.state, review.reason) == ("accepted", "")
                    overturned += _overturned(review, "accepted", project.annotator)
                    project.set_review(object_id, "accepted", expected_modified=versions.get(object_id))
                if args.flag is not None:
                    overturned += _overturned(project.review(args.flag), "flagged", project.annotator)
                    project.set_review(args.flag, "flagged", args.reason, expected_modified=versions.get(args.flag))
            done = [_accepted_text(len(args.accept) - already, already)] if args.accept else []
            done += [f"flagged object {args.flag}"] if args.flag is not None else []
            print(f"{shown(args.project)}: {', '.join(done)} as {project.annotator}")
            for text in overturned:
                print(f"  replaced {text}")
        if args.list is not None:
            objects = {o.id: o for o in project.objects()}
            for review in project.reviews(args.list):
                stored = objects.get(review.object_id)
                kind, attribute = (stored.kind, stored.attribute) if stored is not None else ("?", "")
                version = stored.modified if stored is not None else ""
                print(f"{review.object_id}\t{kind}\t{attribute}\t{review.state}\t{review.reviewer}\t"
                      f"{review.reviewed}\t{review.reason}\t{version}")
        elif not writing:
            from usvips.app.project_contents import objects_text, review_counts, reviews_text

            objects, instants, counts = review_counts(project)
            print(f"{shown(args.project)}: {objects_text(objects, instants)}: {reviews_text(counts)}"
                  + (" (each instant reviewed on its own)" if instants else ""))
    return 0


def _overturned(review, state: str, annotator: str) -> list[str]:
    """One phrase when ``review`` is another reviewer's verdict that ``state`` replaces ("bea's flag of
    object 7 (2026-…): fork hidden"), else none: the history keeps it, the person replacing it is told."""
    if review.state in ("unreviewed", state) or review.reviewer == annotator:
        return []
    verdict = {"flagged": "flag", "accepted": "acceptance"}.get(review.state, review.state)
    reason = f": {review.reason}" if review.reason else ""
    return [f"{review.reviewer or 'someone'}'s {verdict} of object {review.object_id} ({review.reviewed}){reason}"]


def _accepted_text(newly: int, already: int) -> str:
    """``accepted 2``, ``accepted 1, 1 already accepted``, ``1 already accepted``."""
    parts = [f"accepted {newly}"] if newly else []
    return ", ".join(parts + ([f"{already} already accepted"] if already else []))
