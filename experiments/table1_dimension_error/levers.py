"""Fine-tuning levers measured side by side: one `vehloc-train` run per lever, each the base recipe plus the
lever's overrides, one after another on the same machine; the test split is only read for the table (the best
epoch is chosen on a tenth of train). Writes levers.csv, levers.md and levers.png into --out; levers already in
its levers.csv are kept, not run again.

    .venv/bin/python experiments/table1_dimension_error/levers.py --out outputs/levers \
        --base trainer.max_epochs=8 data.batch_size=32 model.freeze_bn_stats=false
    .venv/bin/python experiments/table1_dimension_error/levers.py --out outputs/levers_recipe --only base flip_average ema
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from vehloc.atomic import atomic_path, write_text  # noqa: E402
from vehloc.hardware import cpu_info  # noqa: E402
from vehloc.tables import markdown_table  # noqa: E402
from vehloc.errors import exit_on_error

PROJECT_ROOT = Path(__file__).resolve().parents[2]
LEVERS: dict[str, list[str]] = {
    "base": [],
    "size_224": ["data.input_size_px=224", "data.eval_resize_px=240"],
    "epochs_12": ["trainer.max_epochs=12"],
    "flip_average": ["model.flip_average=true"],
    "ema": ["callbacks=ema"],
    "freeze_bn_stats": ["model.freeze_bn_stats=true"],
    "layer_decay_0.85": ["model.layer_decay=0.85"],
    "mixup_0.2": ["model.mixup_alpha=0.2"],
    "one_cycle_warmup_30pct": ["model.scheduler.warmup_epochs=2.4"],
    "batch_16": ["data.batch_size=16"],
    "lr_x2": ["model.optimizer.lr_backbone=1.0e-3", "model.optimizer.lr_head=1.0e-2"],
    "keep_aspect": ["data.keep_aspect=true"],
    "lite1": ["model=efficientnet_lite1"],
    "lite2": ["model=efficientnet_lite2"],
}


def run_lever(name: str, overrides: list[str], experiment: str, base: list[str], out: Path) -> dict:
    """Train and test one lever; its Table 1 figures and wall time."""
    run_dir = out / name
    command = [str(Path(sys.executable).parent / "vehloc-train"), f"experiment={experiment}", *base, *overrides,
               f"hydra.run.dir={run_dir}", "logger=csv"]
    print(f"[{name}] {' '.join(command[1:])}", flush=True)
    start = time.perf_counter()
    with open(out / f"{name}.log", "w") as log:
        done = subprocess.run(command, cwd=PROJECT_ROOT, stdout=log, stderr=subprocess.STDOUT)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"levers: lever {name} failed (exit {done.returncode}); see {out / f'{name}.log'}")
    accuracy = pd.read_csv(run_dir / "table1" / "accuracy.csv").set_index("metric")["value"]
    row = {"lever": name, "overrides": " ".join(overrides) or "-", "top1_pct": accuracy["top1_pct"],
           "top5_pct": accuracy["top5_pct"], "minutes": seconds / 60}
    print(f"[{name}] top-1 {row['top1_pct']:.1f} %, top-5 {row['top5_pct']:.1f} %, {row['minutes']:.1f} min", flush=True)
    return row


def write_tables(rows: list[dict], out: Path, header: str) -> None:
    table = pd.DataFrame(rows)
    base = table.loc[table["lever"] == "base", "top1_pct"]
    table["top1_vs_base"] = table["top1_pct"] - (base.iloc[0] if len(base) else float("nan"))
    write_text(out / "levers.csv", table.to_csv(index=False, float_format="%.2f"))
    write_text(out / "levers.md", f"{header}\n\n{markdown_table(table)}\n")
    fig, ax = plt.subplots(figsize=(7, 0.45 * len(table) + 1.2))
    ax.barh(table["lever"], table["top1_pct"], color=["0.5" if n == "base" else "tab:blue" for n in table["lever"]])
    for y, (acc, minutes) in enumerate(zip(table["top1_pct"], table["minutes"])):
        ax.text(acc + 0.5, y, f"{acc:.1f} % in {minutes:.1f} min", va="center", fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("test top-1 (%)")
    ax.set_xlim(0, 110)
    ax.set_title(header, fontsize=9)
    fig.tight_layout()
    with atomic_path(out / "levers.png", suffix=".png") as temporary:
        fig.savefig(temporary, dpi=120)
    plt.close(fig)


@exit_on_error("experiments/table1_dimension_error/levers.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="run folder")
    parser.add_argument("--experiment", default="stanford_cars_12")
    parser.add_argument("--base", nargs="*", default=[], help="overrides of every run (the base recipe)")
    parser.add_argument("--only", nargs="*", choices=list(LEVERS), help="these levers only (default: all)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    header = (f"experiment={args.experiment} {' '.join(args.base)} — one run a lever on "
              f"{cpu_info().describe()}")
    done = args.out / "levers.csv"
    rows = pd.read_csv(done).drop(columns="top1_vs_base").to_dict("records") if done.is_file() else []
    for name in args.only or LEVERS:
        if name in {row["lever"] for row in rows}:
            continue
        rows.append(run_lever(name, LEVERS[name], args.experiment, args.base, args.out))
        write_tables(rows, args.out, header)
    print(f"levers: {args.out / 'levers.md'}")


if __name__ == "__main__":
    main()
