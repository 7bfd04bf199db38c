"""The data commands of `vehloc-data`: check a CompCars-format root (the demo set's commands are added by
`vehloc.synth.cli`, which is the console script)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from vehloc.data.compcars import check_images, scan_compcars, summarize
from vehloc.data.specs import read_specs_csv
from vehloc.errors import DataError


def _check(args: argparse.Namespace) -> int:
    if args.specs is not None and not args.specs.is_file():
        raise DataError(f"--specs {args.specs}: " + ("is a folder" if args.specs.is_dir() else "no such file"))
    result = scan_compcars(args.root)
    problems = list(result.problems)
    if result.dataset is not None:
        print(summarize(result.dataset))
        if args.images:
            problems += check_images(result.dataset.train + result.dataset.test)
        specs_path = args.specs or args.root / "specs.csv"
        if args.specs or specs_path.is_file():
            try:
                specs = read_specs_csv(specs_path)
                specs.require(result.dataset.model_ids, result.dataset.model_names)
                print(f"specs: {specs_path} covers all {result.dataset.num_classes} classes")
            except DataError as exc:
                problems += [exc.summary] + exc.problems
    for warning in result.warnings:
        print(f"warning: {warning}")
    if problems:
        print(f"{len(problems)} problem(s):", file=sys.stderr)
        for problem in problems:
            print(f"  {problem}", file=sys.stderr)
        return 1
    print("no problems found")
    return 0


def add_data_commands(commands: argparse._SubParsersAction) -> None:
    """Add `check` to a sub-command parser."""
    check = commands.add_parser("check", help="validate a CompCars-format root and summarize it")
    check.add_argument("root", type=Path)
    check.add_argument("--images", action="store_true", help="also decode every image (slow)")
    check.add_argument("--specs", type=Path, help="specs CSV to check (default: ROOT/specs.csv if present)")
    check.set_defaults(run=_check)
