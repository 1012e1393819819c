"""``usvips render SCENE.json --out DIR``: render a sample project (images, control, observations, truth).

The work is :func:`usvips.app.render.render_scene`; this module parses the arguments and prints."""

from __future__ import annotations

import argparse
from pathlib import Path

from usvips.app.render import render_scene


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("render", help="render a sample project from a scene description")
    parser.add_argument("scene", help="scene description (JSON)")
    parser.add_argument("--out", required=True, help="output directory (created if needed)")
    parser.add_argument("--force", action="store_true", help="replace files of --out that hold a USVIPS calibration "
                        "or project, or the scene itself (each kept as NAME.bak)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    scene = render_scene(args.scene, args.out, replace=args.force)
    print(f"rendered {len(scene.data['pairs'])} pairs of {scene.name} into {Path(args.out)}")
    return 0
