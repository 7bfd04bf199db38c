"""`vehloc-data`: check a CompCars-format root, make the procedural demo set, draw a contact sheet."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from vehloc.atomic import check_output_image
from vehloc.config import ArgumentParser, integer_argument
from vehloc.data.cli import add_data_commands
from vehloc.errors import exit_on_error
from vehloc.synth.contact_sheet import write_contact_sheet
from vehloc.synth.demo_set import MAX_SEED, VIEWS, check_demo_root, make_demo_set


def _make_demo(args: argparse.Namespace) -> int:
    check_demo_root(args.out)
    start_s = time.perf_counter()
    root = make_demo_set(args.out, per_model=args.per_model, seed=args.seed, workers=args.workers, views=args.views)
    print(f"wrote demo set to {root} in {time.perf_counter() - start_s:.1f} s")
    return 0


def _contact_sheet(args: argparse.Namespace) -> int:
    check_output_image(args.out, "contact sheet")
    out = write_contact_sheet(args.root, args.out, per_model=args.per_model)
    print(f"wrote {out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(prog="vehloc-data", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    add_data_commands(commands)

    demo = commands.add_parser("make-demo", help="write the procedural CompCars-format demo set")
    demo.add_argument("out", type=Path, help="a new or empty folder, or one an earlier make-demo wrote")
    demo.add_argument("--per-model", type=integer_argument(2), default=240,
                      help="images per model (at least 2: one for each split)")
    demo.add_argument("--seed", type=integer_argument(0, MAX_SEED), default=0)
    demo.add_argument("--workers", type=integer_argument(1), default=2)
    demo.add_argument(
        "--views", choices=VIEWS, default="traffic",
        help="traffic: fronts and rears from above, as a road camera sees them; road: fronts, rears and sides "
             "from above; any: all round",
    )
    demo.set_defaults(run=_make_demo)

    sheet = commands.add_parser("contact-sheet", help="draw one row of images per model")
    sheet.add_argument("root", type=Path)
    sheet.add_argument("out", type=Path, help="output PNG")
    sheet.add_argument("--per-model", type=integer_argument(1, 100), default=8)
    sheet.set_defaults(run=_contact_sheet)
    return parser


@exit_on_error("vehloc-data")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
