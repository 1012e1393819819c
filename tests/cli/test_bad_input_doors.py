"""Every door of the command line fed malformed input: one clear line, exit 2, nothing changed.

The doors are the leaves of the real parser (``usvips.cli.build_parser``): a command added to the CLI is
in scope at once, and :func:`test_every_command_declares_its_bad_inputs` fails until :data:`DOORS` says
which of its arguments are files or values and how to spoil them. Each door is a valid-looking command
line; each of its declared arguments is spoiled in turn, many ways (a missing file, a folder, an empty
file, binary garbage, text that is not UTF-8, a file cut short at seeded offsets, a column dropped or
renamed, NaN/inf/huge numbers, JSON of the wrong shape or a future version, a file that is not a
project, a project of a newer schema, server URLs a person gets wrong, an unquoted pattern, option values
out of range). For every case:

- the exit status is 2 and stderr is exactly one line naming the file, option or address at fault, with
  neither a traceback nor "internal error";
- every input file is byte-identical afterwards, and a project's tables are as they were;
- no output file or folder is left behind;
- no password of a server address is printed.

The cases are generated from seeded RNGs (the same every run) and run in this process through
``usvips.cli.main``; a failure's test id names the door, the argument and the spoiling.
"""

from __future__ import annotations

import argparse
import random
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from tests.cli.bad_inputs import BAD_URLS, PASSWORDS, ROV, dump, file_spoilings, silent, valid_inputs
from usvips.cli import build_parser, plain_float, whole_number


@dataclass(frozen=True)
class Door:
    """One command line: words with ``@NAME`` for an input file of the prepared folder, ``%NAME`` for an
    output in the case's own folder, ``URL`` for a server address; ``spoil`` maps a word of ``argv`` (an
    ``@NAME``, ``URL``, or an option whose value follows it) to how it is spoiled: ``"file"`` (every way a
    file of its kind can be wrong), ``"missing"``, ``"url"``, ``"glob"`` (the shell expanded a pattern), or
    the bad values themselves (a tuple of words where several follow the option)."""

    argv: str
    spoil: dict[str, str | list] = field(default_factory=dict)


URL_SLOT = {"URL": "url"}

#: every command of the parser → its doors. A command's positional project, its input files and its
#: numbers are spoiled; the command line around them is valid.
DOORS: dict[str, list[Door]] = {
    "open": [Door("open @rov.usvips", {"@rov.usvips": "missing"})],  # any other file opens the window
    "demo": [Door("demo @tank", {"@tank": "file"})],
    "calibrate air": [
        Door("calibrate air --control @control.csv --obs @obs_air.csv --image-size 640x480 --sigma-px 0.5 "
             "--out %cal.json --report %report.json",
             {"@control.csv": "file", "@obs_air.csv": "file",
              "--image-size": ["0x0", "-640x480", "nanx480", "640", "x", "99999999x480"],
              "--sigma-px": ["0", "-1", "nan", "inf", "x"]}),
        Door("calibrate air --control @control.csv --obs @obs_air.csv --holdout 0.2 --seed 3 --out %cal.json",
             {"--holdout": ["-0.1", "1", "1.5", "nan", "inf"], "--seed": ["x"]}),
        Door("calibrate air --control @control.csv --obs @obs_air.csv --image-size 640x480 --prior k1=0:0.1 "
             "--fix p1 --free k2 --out %cal.json",
             {"--prior": ["k1", "k1=x:0.1", "k1=0:-1", "k1=nan:0.1", "k1=0:0", "nosuch=0:1"],
              "--fix": ["=3", "p1=nan", "nosuch"], "--free": ["nosuch"]}),
        Door("calibrate air --target @target.json --images @left.png @right.png --out %cal.json",
             {"@target.json": "file", "@left.png": "file"}),
        Door("calibrate air --target @target.json --left-images @left.png --right-images @right.png "
             "--out %cal.json", {"--left-images": "glob"}),
        Door("calibrate air --target @target.json --project @rov.usvips --video video --every 5 --max-views 30 "
             "--out %cal.json",
             {"--every": ["0", "-1", "x"], "--max-views": ["0", "-5"], "--video": ["nosuch", "measure1"],
              "@rov.usvips": "file"}),
    ],
    "calibrate water": [
        Door("calibrate water --base @cal_air.json --housing flat-port --control @control.csv --obs @obs_water.csv "
             "--image-size 640x480 --port-distance 0.02 --glass-thickness 0.016 --n-glass 1.65 --n-water 1.34 "
             "--out %cal.json",
             {"@cal_air.json": "file", "@obs_water.csv": "file",
              "--port-distance": ["x", "nan", "-1", "0.02:-1", "0.02:nan", "inf", "0.02:x:1"],
              "--glass-thickness": ["-0.016", "nan", "0"], "--n-glass": ["0.5", "nan", "x", "-1.5"],
              "--n-water": ["0", "inf", "1e999"]}),
    ],
    "intersect": [
        Door("intersect --calibration @cal.json --obs @obs_water.csv --out %points.csv --pointing-sigma 0.3",
             {"@cal.json": "file", "@obs_water.csv": "file",
              "--pointing-sigma": ["0", "-1", "nan", "inf", "x"]}),
        Door("intersect --calibration @cal.json --obs @obs_water.csv --out %points.csv --station 0",
             {"--station": ["99", "nosuch", "-1"]}),
    ],
    "measure": [
        Door("measure --calibration @cal.json --picks @picks.csv --out %objects.csv --pointing-sigma 0.3",
             {"@cal.json": "file", "@picks.csv": "file", "--pointing-sigma": ["0", "nan", "-2"]}),
        Door("measure --calibration @cal.json --picks @picks.csv --out %objects.csv --station 0",
             {"--station": ["99", "nosuch"]}),
        Door("measure --project @rov.usvips --pair measure1 --picks @picks.csv",
             {"@rov.usvips": "file", "--pair": ["nosuch", "video"], "@picks.csv": "file"}),
        Door("measure --project @rov.usvips --video video --frame 5 --picks @picks.csv",
             {"--frame": ["-1", "100000", "x", "nan"], "--video": ["nosuch", "measure1"]}),
    ],
    "project new": [Door("project new %new.usvips --from @tank", {"@tank": "file"})],
    "project info": [Door("project info @rov.usvips", {"@rov.usvips": "file"}),
                     Door("project info URL", URL_SLOT)],
    "project accept-media": [Door("project accept-media @rov.usvips @left.png",
                                  {"@rov.usvips": "file", "@left.png": "missing"})],
    "project relocate-media": [Door("project relocate-media @rov.usvips MEDIA @left.mp4",
                                    {"@rov.usvips": "file", "MEDIA": ["/no/such/video.avi", ""],
                                     "@left.mp4": "file"})],
    "project import": [
        Door("project import @rov.usvips --control @control.csv", {"@rov.usvips": "file", "@control.csv": "file"}),
        Door("project import @rov.usvips --obs @obs_air.csv --pair fz --role calibration-water",
             {"@obs_air.csv": "file", "--role": ["bogus", ""]}),
        Door("project import @rov.usvips --calibration @cal.json --active-for water2",
             {"@cal.json": "file", "--active-for": ["nosuch"]}),
    ],
    "project export": [Door("project export @rov.usvips %objects.csv", {"@rov.usvips": "file"}),
                       Door("project export @rov.usvips %ga --format globalarchive --reader fz",
                            {"--format": ["bogus"]})],
    "project add-pairs": [
        Door("project add-pairs @rov.usvips --left @left.png --right @right.png --label-prefix fz- --pair-by order",
             {"@rov.usvips": "file", "@left.png": "file", "@right.png": "file", "--pair-by": ["bogus"],
              "--label-prefix": ["a/b", "../", ".x", "a\\b"]}),
        Door("project add-pairs @rov.usvips --left @left.png --right @right.png --label-prefix fz- --pair-by time "
             "--max-dt 2", {"--max-dt": ["nan", "-1", "inf", "x"]}),
    ],
    "project add-video": [Door("project add-video @rov.usvips --left @left.mp4 --right @right.mp4 --label fz "
                               "--medium water",
                               {"@rov.usvips": "file", "@left.mp4": "file", "@right.mp4": "file",
                                "--label": ["video", "measure1"], "--medium": ["mud"]})],
    "project set-metadata": [
        Door("project set-metadata @rov.usvips --opcode OP1 --date 2024-01-02 --time 10:00 --latitude -32 "
             "--longitude 115 --depth 10 --successful-count yes",
             {"@rov.usvips": "file", "--date": ["2024-13-01", "x", "2024-02-30", "02/01/2024"],
              "--time": ["25:00", "x", "10:61", "-1:00"], "--latitude": ["91", "nan", "x", "-inf"],
              "--longitude": ["181", "inf", "-1e999"], "--depth": ["-1", "nan", "1e999"],
              "--successful-count": ["maybe"]}),
        Door("project set-metadata @rov.usvips --video video --opcode OP1", {"--video": ["nosuch", "measure1"]}),
    ],
    "project set-georeference": [
        Door("project set-georeference @rov.usvips --latitude -32 --longitude 115 --depth 0 --heading 10",
             {"@rov.usvips": "file", "--latitude": ["91", "nan", "x"], "--longitude": ["-181", "inf"],
              "--depth": ["nan", "-1e999", "x"], "--heading": ["nan", "inf", "x"]}),
        Door("project set-georeference @rov.usvips --points @geo.csv", {"@geo.csv": "file"}),
    ],
    "project check": [
        Door("project check @rov.usvips --out %check.csv --max-rms-mm 20 --max-precision 10 --max-range-m 8 "
             "--fail-on error",
             {"@rov.usvips": "file", "--max-rms-mm": ["0", "-1", "nan", "inf"], "--max-precision": ["0", "-5", "nan"],
              "--max-range-m": ["0", "-1", "nan"], "--fail-on": ["never"]}),
        Door("project check @rov.usvips --sigma --replicas 4 --seed 1 --pointing-sigma 0.3",
             {"--replicas": ["0", "-1", "x", "100000000"], "--seed": ["-1"], "--pointing-sigma": ["0", "nan", "-1"]}),
    ],
    "project push": [Door("project push @rov.usvips URL", {"@rov.usvips": "file", **URL_SLOT})],
    "project pull": [Door("project pull URL %pulled.usvips", URL_SLOT)],
    "project history": [Door("project history @rov.usvips --object 1", {"@rov.usvips": "file", "--object": ["x"]}),
                        Door("project history URL", URL_SLOT)],
    "project set-campaign": [
        Door("project set-campaign @rov.usvips --campaign-id 2024-01_Fuzz_stereo-BRUVs --start-date 2024-01-01 "
             "--end-date 2024-01-05",
             {"@rov.usvips": "file", "--start-date": ["2024-13-01", "x"], "--end-date": ["2023-12-31", "2024-02-30"]}),
        Door("project set-campaign URL --comment x", URL_SLOT)],
    "project double-read": [
        Door("project double-read @rov.usvips --readers A B --tolerance-s 0.5 --gate-m 0.3 --k 2 --csv %dr.csv",
             {"@rov.usvips": "file", "--tolerance-s": ["-1", "nan", "inf"], "--gate-m": ["0", "-1", "nan"],
              "--k": ["0", "-1", "nan"], "--readers": [("A", "A")]}),
        Door("project double-read @rov.usvips --readers A B --tolerance-frames 2",
             {"--tolerance-frames": ["-1", "x"]})],
    "project review": [
        Door("project review @rov.usvips --accept 1",
             {"@rov.usvips": "file", "--accept": ["99999", "x", "-1", "1@fake-stamp"]}),
        Door("project review @rov.usvips --flag 1 --reason wrong", {"--flag": ["99999", "x@1"], "--reason": [""]}),
        Door("project review @rov.usvips --list unreviewed", {"--list": ["bogus"]}),
        Door("project review URL --list unreviewed", URL_SLOT)],
    "project pointing": [
        Door("project pointing @rov.usvips --from-repeats fz --gate-px 8", {"@rov.usvips": "file",
                                                                             "--gate-px": ["0", "-1", "nan"]}),
        Door("project pointing @rov.usvips --use-estimate 1", {"--use-estimate": ["99", "-1", "x"]})],
    "render": [
        Door("render @scene.json --out %rendered", {"@scene.json": "file"}),
        Door("render --target @target.json --views 2 --image-size 160x120 --supersample 1 --noise 1 --fps 10 "
             "--video-frames 0 --distance 0.5 1.0 --tilt 15 40 --out %rendered",
             {"@target.json": "file", "--views": ["0", "-1", "100000000"], "--fps": ["0", "-1"],
              "--video-frames": ["-1", "100000000"], "--distance": [("-1", "1"), ("1", "0.5"), ("nan", "1")],
              "--tilt": [("95", "100"), ("40", "15"), ("nan", "3")], "--image-size": ["0x0", "1x1", "x"],
              "--supersample": ["0", "-1", "1000"], "--noise": ["-1", "nan", "inf"]}),
        Door("render --target @target.json --housing flat-port --housing-value g=0.05 --views 2 "
             "--image-size 160x120 --supersample 1 --out %rendered",
             {"--housing-value": ["x", "g=nan", "zz=1", "g=-1"]}),
        Door("render --target @target.json --calibration @cal.json --views 2 --image-size 640x480 "
             "--supersample 1 --out %rendered", {"@cal.json": "file"}),
    ],
    "bench": [Door("bench --only NAME --scale 0.01", {"--only": ["nosuch"]}),
              Door("bench --scale 0.01 --list", {"--scale": ["0", "-1", "nan", "inf", "x"]})],
    "calibration import": [
        Door("calibration import @stereo.yml --out %c.json --image-size 1280x960 --sigma0 0.5 --unit m",
             {"@stereo.yml": "file", "--image-size": ["0x0", "x", "-5x5"], "--sigma0": ["0", "-1", "nan", "inf"],
              "--unit": ["furlong"]}),
    ],
    "calibration export": [Door("calibration export @cal.json --out %c.yml", {"@cal.json": "file"})],
    "calibration report": [Door("calibration report @cal.json --out %r.pdf --check @obs_water.csv "
                                "--check-control @control.csv",
                                {"@cal.json": "file", "@obs_water.csv": "file", "@control.csv": "file"})],
    "plan": [Door("plan --calibration @cal.json --range 1:3:3 --json --sigma-px 0.3 --length 0.3",
                  {"@cal.json": "file", "--sigma-px": ["0", "nan", "-1"], "--length": ["0", "-1", "inf"],
                   "--range": ["1:3:0", "x", "1:nan:3"]}),
             Door("plan --focal-px 800 --image-size 640x480 --baseline 0.3 --housing flat-port --port g=0.05 "
                  "--range 1:3:3 --json", {"--port": ["x", "g=nan", "zz=1", "g=-1"]})],
    "video sync": [Door("video sync @rov.usvips --pair video --max-offset 10 --dry-run",
                        {"@rov.usvips": "file", "--pair": ["nosuch", "measure1"], "--max-offset": ["-1", "x", "0"]}),
                   Door("video sync @rov.usvips --pair video --method image --calibration 2 --dry-run",
                        {"--calibration": ["99", "-1"]})],
    "video set-offset": [Door("video set-offset @rov.usvips --pair video 3",
                              {"@rov.usvips": "file", "3": ["100000", "x", "-100000"], "--pair": ["nosuch"]})],
    "video export-frame": [Door("video export-frame @rov.usvips --pair video --frame 5 --out %frames",
                                {"@rov.usvips": "file", "--frame": ["-1", "100000"],
                                 "--pair": ["nosuch", "measure1"]})],
    "video take-pair": [Door("video take-pair @rov.usvips --pair video --frame 5 --label fz",
                             {"@rov.usvips": "file", "--frame": ["-1", "100000"],
                              "--label": ["measure1", "", "../x", ".hidden", "a/b"],
                              "--pair": ["nosuch"]})],
    "video proxy": [Door("video proxy @rov.usvips --pair video --delete", {"@rov.usvips": "file",
                                                                           "--pair": ["nosuch", "measure1"]})],
    "video period": [Door("video period @rov.usvips --pair video --add fz 1 3",
                          {"@rov.usvips": "file", "--add": [("fz", "3", "1"), ("fz", "-1", "3"),
                                                            ("fz", "1", "100000"), ("fz", "x", "3"), ("", "1", "3")]})],
    "video calibration-views": [
        Door("video calibration-views @rov.usvips --pair video --target @target.json --every 5 --max-views 30 "
             "--max-blur 4 --focal 640 --out %views.csv --quiet",
             {"@rov.usvips": "file", "@target.json": "file", "--every": ["0", "-1"], "--max-views": ["0", "-1"],
              "--max-blur": ["0", "nan", "-1"], "--focal": ["0", "nan", "-640"], "--pair": ["nosuch"]})],
    "batch intersect": [Door("batch intersect @obs_water.csv --calibration @cal.json --out-dir %batch --jobs 1",
                             {"@obs_water.csv": "file", "@cal.json": "file", "--jobs": ["0", "-1", "x"]}),
                        Door("batch intersect @obs_water.csv --calibration @cal.json --out-dir %batch "
                             "--scheduler local:1", {"--scheduler": ["local:0", "local:1000", "local:x", "bogus"]})],
    "batch export": [Door("batch export @rov.usvips --format csv --out-dir %batch --jobs 1",
                          {"@rov.usvips": "file", "--format": ["bogus"]}),
                     Door("batch export URL --format csv --out-dir %batch --jobs 1", URL_SLOT)],
    "target describe": [
        Door("target describe chessboard --cols 8 --rows 5 --square 20 --out %t.json",
             {"chessboard": ["bogus"], "--cols": ["0", "-1", "100000", "1"], "--rows": ["0", "x"],
              "--square": ["0", "-1", "nan", "inf"]}),
        Door("target describe charuco --cols 7 --rows 5 --square 20 --marker 15 --dictionary 5X5_100 --out %t.json",
             {"--marker": ["0", "25", "nan"], "--dictionary": ["bogus"]}),
        Door("target describe circle-grid --cols 4 --rows 5 --spacing 20 --diameter 10 --out %t.json",
             {"--spacing": ["0", "-1", "nan"], "--diameter": ["0", "30", "inf"], "--cols": ["1"]}),
        Door("target describe target-field --control @control.csv --mark disc --size 10 --out %t.json",
             {"@control.csv": "file", "--size": ["0", "-1", "nan"]}),
    ],
    "target print": [Door("target print @target.json --out %t.pdf", {"@target.json": "file"})],
    "target detect": [Door("target detect @target.json @left.png", {"@target.json": "file", "@left.png": "file"})],
    "species import": [Door("species import @rov.usvips @species.csv", {"@rov.usvips": "file",
                                                                       "@species.csv": "file"}),
                       Door("species import URL @species.csv", URL_SLOT)],
    "detect": [
        Door("detect @rov.usvips --pair measure1 --model @fish.toml",
             {"@rov.usvips": "file", "--pair": ["nosuch", "video"], "@fish.toml": "file"}),
        Door("detect @rov.usvips --video video --every 5 --frames 0:3 --model @fish.toml",
             {"--every": ["0", "-1", "x"], "--frames": ["3:1", "x", "0:99999", "-1:2", "1", "0:" + "9" * 25],
              "--video": ["nosuch", "measure1"]}),
        Door("detect @rov.usvips --review-sigma --model @fish.toml", {"@rov.usvips": "file", "@fish.toml": "file"}),
        Door("detect @rov.usvips --max-n", {"@rov.usvips": "file"}),
    ],
    "batch detect": [Door("batch detect @rov.usvips --model @fish.toml --every 5 --jobs 1",
                          {"@rov.usvips": "file", "@fish.toml": "file", "--every": ["0", "-1", "x"]}),
                     Door("batch detect URL --model @fish.toml --jobs 1", URL_SLOT)],
    "species list": [Door("species list @rov.usvips", {"@rov.usvips": "file"}),
                     Door("species list URL", URL_SLOT)],
}


#: doors of commands that other branches of this session add (issue 33's ``target field``): in scope as soon
#: as the parser has them
DOORS_TO_COME: dict[str, list[Door]] = {
    "target field": [
        Door("target field @rov.usvips --pair water1 --clicks @clicks.csv --calibration active --mark disc",
             {"@rov.usvips": "file", "@clicks.csv": "file", "--pair": ["nosuch"], "--calibration": ["99", "x"],
              "--mark": ["square"]}),
        Door("target field @rov.usvips --pair water1 --clicks @clicks.csv --control @control.csv --calibration 2 "
             "--store --accept-doubtful 2", {"@control.csv": "file", "--accept-doubtful": ["nosuch", "x,y"]}),
    ],
}


def commands() -> list[str]:
    """Every leaf command of the real parser, as typed: ``project import``, ``plan`` …"""
    found: list[str] = []

    def walk(parser: argparse.ArgumentParser, path: list[str]) -> None:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs:
            found.append(" ".join(path))
        for sub in subs:
            for name, child in sub.choices.items():
                walk(child, [*path, name])

    walk(build_parser("*"), [])
    return found


def _declared() -> dict[str, list[Door]]:
    """:data:`DOORS`, and those of :data:`DOORS_TO_COME` whose command the parser has."""
    present = set(commands())
    return {**DOORS, **{name: doors for name, doors in DOORS_TO_COME.items() if name in present}}


def test_every_command_declares_its_bad_inputs():
    """A command of the parser with no doors here, or a door with nothing spoiled, is a door not fuzzed."""
    missing = sorted(set(commands()) - set(_declared()))
    assert not missing, f"commands with no bad-input cases declared in DOORS: {missing}"
    assert not sorted(set(DOORS) - set(commands())), "DOORS names commands the parser does not have"
    for name, doors in _declared().items():
        assert any(_cases_of(name, i, door) for i, door in enumerate(doors)), f"{name}: no case"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    """A copy of :func:`valid_inputs` for the commands, and beside it, in ``pristine``, another to compare
    with and to restore from."""
    folder = tmp_path_factory.mktemp("doors")
    shutil.copytree(valid_inputs(), folder / "inputs")
    shutil.copytree(valid_inputs(), folder / "pristine")
    return folder / "inputs"


# ---------------------------------------------------------------------------- the cases
@dataclass(frozen=True)
class Case:
    """One malformed input of one door: ``make(work)`` writes what it needs into the case's folder and
    returns the words that replace the spoiled one; the error must name one of ``culprits``."""

    door: str
    label: str
    argv: tuple[str, ...]
    index: int  # the first word replaced
    make: Callable[[Path], list[str]]
    culprits: tuple[str, ...]
    secret: str | None = None
    width: int = 1  # how many words are replaced


def _cases_of(command: str, number: int, door: Door) -> list[Case]:
    argv = tuple(door.argv.split())
    cases: list[Case] = []
    for word, how in door.spoil.items():
        assert word in argv, f"{command}: {word} is not a word of {door.argv!r}"
        index = argv.index(word)
        rng = random.Random(f"{command}#{number}:{word}")
        door_id = f"{command}#{number}"
        if how == "url":
            for label, url in BAD_URLS:
                secret = next(p for p in PASSWORDS if p in url)
                cases.append(Case(door_id, f"URL {label}", argv, index, lambda work, url=url: [url],
                                  ("postgres", "127.0.0.1", "survey", "::1"), secret))
        elif how == "glob":
            files = ["@left.png", "@right.png", "@left.png", "@right.png"]
            cases.append(Case(door_id, f"{word} unquoted pattern", argv, index + 1,
                              lambda work, files=files: files, ("quote", "unrecognized")))
        elif how in ("file", "missing"):
            name = word[1:]
            spoilings = file_spoilings(name, valid_inputs() / name, rng)
            option = (argv[index - 1],) if argv[index - 1].startswith("--") else ()
            for label, make in spoilings if how == "file" else spoilings[:1]:
                cases.append(Case(door_id, f"{name} {label}", argv, index, make, (f"bad_{name}", *option)))
        else:
            for value in how:
                words = list(value) if isinstance(value, tuple) else [value]
                at = index if not word.startswith("-") else index + 1
                cases.append(Case(door_id, f"{word} {' '.join(words)!r}", argv, at, lambda work, words=words: words,
                                  _value_culprits(word, words), width=len(words)))
    door_id = f"{command}#{number}"  # an output pointed at one of the command's own inputs: refused, kept
    for out in (w for w in argv if w.startswith("%")):
        for source in dict.fromkeys(w for w in argv if w.startswith("@") and (valid_inputs() / w[1:]).is_file()):
            cases.append(Case(door_id, f"{out[1:]} onto the input {source[1:]}", argv, argv.index(out),
                              lambda work, source=source: [source], (source[1:],)))
    return cases


def _value_culprits(word: str, words: list[str]) -> tuple[str, ...]:
    """What an error about a bad value may name: the option (with or without its dashes), or the value
    itself (a label or a number of two characters or more; the name of a NAME=VALUE)."""
    named = [w.partition("=")[0] if "=" in w else w for w in words if "=" in w or len(w) >= 2]
    quoted = [f"'{w}'" for w in words]  # as argparse quotes a value it refuses
    return (word, word.lstrip("-"), *named, *quoted) if word.startswith("-") else (*named, *quoted, word.lower())


def _number_options(command: str) -> dict[str, type]:
    """Every option of ``command`` that takes one number (float or int), by its long name (the parser reads
    ``type=float`` options through :func:`usvips.cli.plain_float`, ``type=int`` ones through ``whole_number``)."""
    parser = build_parser("*")
    for word in command.split():
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = sub.choices[word]
    return {max(a.option_strings, key=len): float if a.type is plain_float else a.type for a in parser._actions
            if a.option_strings and a.type in (float, int, whole_number, plain_float) and a.nargs is None}


def _non_finite_cases(command: str, doors: list[Door]) -> list[Case]:
    """Each number option of the command given NaN, infinity and an overflowing text, on the first of its
    doors whose command line has it, else added to its first door: never silently taken."""
    cases = []
    for option, kind in sorted(_number_options(command).items()):
        number, door = next(((i, d) for i, d in enumerate(doors) if option in d.argv.split()), (0, doors[0]))
        argv = tuple(door.argv.split())
        if option not in argv:
            argv = (*argv, option, "0")
        at = argv.index(option) + 1
        for value in (("nan", "inf", "-inf", "1e999") if kind is float else ("1e3", "9" * 30)):
            cases.append(Case(f"{command}#{number}", f"{option} {value!r} (every number option)", argv, at,
                              lambda work, value=value: [value], _value_culprits(option, [value])))
    return cases


ALL_CASES = [case for command, doors in _declared().items() for number, door in enumerate(doors)
             for case in _cases_of(command, number, door)]
ALL_CASES += [case for command, doors in _declared().items() for case in _non_finite_cases(command, doors)]


# ---------------------------------------------------------------------------- running a case
def _state(folder: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns) for p in folder.rglob("*")
            if p.is_file() and not p.name.endswith(("-wal", "-shm", "-journal"))}


def _contents(folder: Path) -> dict[str, bytes]:
    """The files of a case's folder (the spoiled inputs) and their bytes, SQLite's companions left out."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*")
            if p.is_file() and not p.name.endswith(("-wal", "-shm", "-journal"))}


def _argv(case: Case, inputs: Path, work: Path) -> list[str]:
    words = list(case.argv)
    words[case.index:case.index + case.width] = case.make(work)
    resolved = []
    for word in words:
        if word.startswith("@"):
            resolved.append(str(inputs / word[1:]))
        elif word.startswith("%"):
            resolved.append(str(work / word[1:]))
        elif word == "URL":
            resolved.append(BAD_URLS[0][1])
        elif word == "MEDIA":
            resolved.append(str(ROV / "video_left.avi"))  # as the project records it
        else:
            resolved.append(word)
    return resolved


@pytest.mark.parametrize("case", ALL_CASES, ids=[f"{c.door}|{c.label}" for c in ALL_CASES])
def test_malformed_input_is_one_line_exit_2_and_changes_nothing(inputs, tmp_path, case):
    work = tmp_path / "work"
    work.mkdir()
    before = _state(inputs)
    argv = _argv(case, inputs, work)
    made = {str(p.relative_to(work)) for p in work.rglob("*")}
    spoiled = _contents(work)
    code, out, err = silent(argv)
    problems = []
    lines = err.strip().splitlines()
    if code != 2:
        problems.append(f"exit {code}")
    if len(lines) != 1:
        problems.append(f"{len(lines)} lines on stderr")
    if "Traceback" in err or "internal error" in err:
        problems.append("a traceback or an internal error")
    if code == 2 and len(lines) == 1 and not any(c in err for c in case.culprits):
        problems.append(f"names none of {case.culprits}")
    if case.secret and (case.secret in out + err):
        problems.append("printed the password")
    left = {str(p.relative_to(work)) for p in work.rglob("*")} - made
    left = {name for name in left if not name.endswith(("-wal", "-shm", "-journal"))}
    if left:
        problems.append(f"left {sorted(left)}")
    now = _contents(work)
    if any(now.get(name) != data for name, data in spoiled.items()):
        problems.append("changed or removed the spoiled file")
    changed = _changed_inputs(inputs, before)
    if changed:
        problems.append(f"changed {changed}")
    assert not problems, f"{' '.join(argv)}\n  {'; '.join(problems)}\n  stderr: {err!r}"


def _changed_inputs(inputs: Path, before: dict[str, tuple[int, int]]) -> list[str]:
    """The inputs no longer as they were (a project: its tables; any other file: its bytes), each put back."""
    pristine = inputs.parent / "pristine"
    after = _state(inputs)
    changed = sorted(set(before) ^ set(after))
    for name in set(before) & set(after):
        if before[name] == after[name]:
            continue
        path, original = inputs / name, pristine / name
        same = (dump(path) == dump(original) if name.endswith(".usvips")
                else path.read_bytes() == original.read_bytes())
        if not same:
            changed.append(name)
        shutil.copy2(original, path)
    for name in set(after) - set(before):
        (inputs / name).unlink()
    for name in set(before) - set(after):
        shutil.copy2(pristine / name, inputs / name)
    return changed
