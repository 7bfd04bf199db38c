"""Compare two runs of the localization benchmark on the same seeds, case by case: did a change move a gate, or
only the cases that chance moves?

    python experiments/localization_benchmark/run.py split=dev out=runs/dev_before
    python experiments/localization_benchmark/run.py split=dev out=runs/dev_after localize.fit.shadow_restart_mm=0
    python experiments/localization_benchmark/compare.py runs/dev_before runs/dev_after --out runs/dev_compare

Reads each run's `cases.csv` (a run folder or the file); both must hold the same seeds, drawn as the same cases.
Writes into `--out`: `gates.csv` (per split and gate: each run's rate, the seeds gained and lost, the exact McNemar
p-value), `errors.csv` (per error column: cases better and worse, the median change of those that moved, the sign
test), `changed_cases.csv`, `groups.csv` (per split, view, colour group, distance band and model: each gate's rate
before and after), `compare.md` and `compare.png` (each moved case's errors before against after).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from vehloc.atomic import check_output_dir
from vehloc.benchmark.paired import compare_runs, read_cases
from vehloc.benchmark.paired_report import gates_table, write_comparison
from vehloc.errors import exit_on_error
from vehloc.tables import markdown_table


@exit_on_error("experiments/localization_benchmark/compare.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("before", type=Path, help="the first run's folder (or its cases.csv)")
    parser.add_argument("after", type=Path, help="the second run's folder (or its cases.csv)")
    parser.add_argument("--out", type=Path, required=True, help="the folder to write the comparison in")
    args = parser.parse_args()
    check_output_dir(args.out)
    names = (str(args.before), str(args.after))
    comparison = compare_runs(read_cases(args.before), read_cases(args.after), names)
    written = write_comparison(comparison, args.out, names)
    shown = gates_table(comparison).drop(columns=["seeds gained", "seeds lost"])
    print(markdown_table(shown, "{:.3g}"))
    print(f"{len(comparison.changed)} cases changed; wrote " + ", ".join(str(p) for p in written))


if __name__ == "__main__":
    main()
