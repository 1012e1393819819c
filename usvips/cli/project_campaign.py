"""``usvips project set-campaign PROJECT [--campaign-id ID] [--project-name NAME] [--method M] …`` stores
the campaign GlobalArchive files the project's deployments under (options not given keep their stored
values; ``--clear`` removes it), and ``usvips project export PROJECT FOLDER --format globalarchive`` writes
the campaign's metadata, count and length tables beside the EventMeasure-style tables CheckEM reads, all
named by the CampaignID (:mod:`usvips.app.archive_export`)."""

from __future__ import annotations

import argparse
import sys

from usvips.core.errors import InvalidParameterError, UsvipsError

#: Campaign field → (option, help)
CAMPAIGN_OPTIONS = {
    "campaign_id": ("--campaign-id", "GlobalArchive's CampaignID, YYYY-MM_Project.name_Method (starts the file names)"),
    "project": ("--project-name", "GlobalArchive's Project the campaign belongs to"),
    "method": ("--method", "sampling method, e.g. stereo-BRUVs, stereo-DOVs"),
    "sampling_design": ("--sampling-design", "e.g. 'stratified random, 4 strata'"),
    "submitter": ("--submitter", "who submits the campaign to GlobalArchive"),
    "institution": ("--institution", None),
    "start_date": ("--start-date", "first day of the campaign, YYYY-MM-DD"),
    "end_date": ("--end-date", "last day of the campaign, YYYY-MM-DD"),
    "image_analysis": ("--image-analysis", "how the imagery was annotated (default USVIPS)"),
    "comment": ("--comment", None),
}


def register_campaign_action(actions: argparse._SubParsersAction) -> None:
    campaign = actions.add_parser("set-campaign", help="store the campaign (GlobalArchive's CampaignID, project, "
                                  "method, sampling design, submitter …); options not given keep their stored values")
    campaign.add_argument("project", help="the project file, or postgresql://USER@HOST[:PORT]/DATABASE")
    for name, (option, text) in CAMPAIGN_OPTIONS.items():
        campaign.add_argument(option, dest=f"campaign_{name}", help=text)
    campaign.add_argument("--clear", action="store_true", help="remove the stored campaign")
    campaign.set_defaults(handler=run_set_campaign)


def run_set_campaign(args: argparse.Namespace) -> int:
    from usvips.core import validation
    from usvips.core.campaign import Campaign
    from usvips.store.opening import open_project

    given = {name: getattr(args, f"campaign_{name}") for name in CAMPAIGN_OPTIONS
             if getattr(args, f"campaign_{name}") is not None}
    for name, value in given.items():
        validation.printable(CAMPAIGN_OPTIONS[name][0], value)
        if not str(value).strip():
            raise InvalidParameterError(CAMPAIGN_OPTIONS[name][0], "is empty: give a value (--clear removes the "
                                        "whole campaign)")
    with open_project(args.project) as project:
        stored = project.campaign()  # the version this command read: a colleague's change since is refused
        if args.clear:
            if given:
                raise UsvipsError("--clear removes the campaign; give no other values with it")
            project.set_campaign(None, expected=stored)
            print("cleared the campaign")
            return 0
        values = {} if stored is None else stored.to_dict()
        values.update(given)
        try:
            campaign = Campaign(**values)
        except InvalidParameterError as error:  # named as the option the user typed
            raise InvalidParameterError(CAMPAIGN_OPTIONS[error.parameter][0], error.problem) from None
        project.set_campaign(campaign, expected=stored)
    missing = campaign.missing()
    print(f"stored campaign {campaign.campaign_id or '(no CampaignID yet)'}"
          + (f"; a GlobalArchive export still needs {', '.join(CAMPAIGN_OPTIONS[m][0] for m in missing)}"
             if missing else ""))
    return 0


def run_archive_export(args: argparse.Namespace) -> int:
    """``export … --format globalarchive``: OUT is the folder the tables go into, made when it does not
    exist (in an existing folder) and removed again when the export is refused."""
    from usvips.app.archive_export import export_archive_folder
    from usvips.store.location import is_server_location
    from usvips.store.opening import open_project

    skipped: list[str] = []
    warnings: list[str] = []
    local = None if is_server_location(args.project) else args.project
    with open_project(args.project, read_only=True) as project:
        try:
            written = export_archive_folder(project, args.out, local, args.force, args.reader, skipped, warnings)
        except InvalidParameterError as error:
            if error.parameter != "folder":
                raise
            raise InvalidParameterError("OUT", error.problem) from None
    for reason in skipped:
        print(f"skipped {reason}")
    for warning in warnings:
        print(f"warning: {warning}; --reader NAME exports one reader's", file=sys.stderr)
    print(f"wrote {len(written)} GlobalArchive/CheckEM tables to {args.out}: "
          + ", ".join(path.name for path in written))
    return 0
