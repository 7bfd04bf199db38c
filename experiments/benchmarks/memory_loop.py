"""The localization's memory over a long video: the shared highway clip played `--passes` times in a row through
one `Localizer` (one video of it looped, the frame index running on), the process's resident memory and the tracks
held sampled every `--every` frames. With tracks removed once lost (`tracker.max_lost_frames`), the memory after the
last pass stays within 10 % of that after the first.

    python experiments/benchmarks/memory_loop.py --calibration outputs/highway/calibration.json \
        --model outputs/stanford_cars_12.onnx --out outputs/bench_memory

The clip's settings are `experiment=highway`, as in `experiments/real_video/`. The records are counted, not kept:
this measures the pipeline, not the list a caller keeps. Writes `memory.csv` (one row per sample), `memory.md` (one
row per pass) and `memory.png` into `--out`.
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from vehloc.atomic import atomic_path, write_text  # noqa: E402
from vehloc.geometry.camera_calibration import read_calibration  # noqa: E402
from vehloc.geometry.pipeline.localize import Localizer  # noqa: E402
from vehloc.geometry.pipeline.settings import LocalizeSettings  # noqa: E402
from vehloc.geometry.pipeline.video import iter_frames  # noqa: E402
from vehloc.hardware import cpu_info  # noqa: E402
from vehloc.infer.classifier import VehicleClassifier  # noqa: E402
from vehloc.tables import markdown_table  # noqa: E402
from vehloc.errors import exit_on_error

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "real_video"))
from highway import EXPERIMENT, VIDEO  # noqa: E402

MAX_GROWTH = 0.10
"""The memory after the last pass may exceed that after the first by at most this fraction."""


def resident_mib() -> float:
    """The process's resident memory now (Linux: VmRSS of /proc/self/status), in MiB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS in /proc/self/status: this benchmark reads Linux's process status")


def run(localizer: Localizer, passes: int, every: int) -> pd.DataFrame:
    """Play the clip `passes` times through `localizer`; a sample of memory, tracks held and records made every
    `every` frames and at the end of each pass."""
    rows, frame_index, records, removed = [], 0, 0, 0
    start = time.perf_counter()
    for pass_number in range(1, passes + 1):
        for frame in iter_frames(VIDEO):
            records += len(localizer.process(frame_index, frame))
            frame_index += 1
            if frame_index % every == 0:
                rows.append({"pass": pass_number, "frame": frame_index, "rss_mib": resident_mib(),
                             "tracks_held": len(localizer.tracker.tracks), "tracks_started": localizer.tracker.started,
                             "records": records, "end_of_pass": False})
        gc.collect()
        rows.append({"pass": pass_number, "frame": frame_index, "rss_mib": resident_mib(),
                     "tracks_held": len(localizer.tracker.tracks), "tracks_started": localizer.tracker.started,
                     "records": records, "end_of_pass": True})
        print(f"pass {pass_number}: {frame_index} frames, {records} records, {len(localizer.tracker.tracks)} tracks "
              f"held, {rows[-1]['rss_mib']:.1f} MiB resident ({time.perf_counter() - start:.0f} s)", flush=True)
    return pd.DataFrame(rows)


def figure(samples: pd.DataFrame, path: Path) -> Path:
    fig, (memory, tracks) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    memory.plot(samples["frame"], samples["rss_mib"], color="tab:blue")
    memory.set_ylabel("resident memory (MiB)")
    tracks.plot(samples["frame"], samples["tracks_held"], color="tab:orange")
    tracks.set_ylabel("tracks held")
    tracks.set_xlabel("frame (the clip looped)")
    for frame in samples[samples["end_of_pass"]]["frame"]:
        for axis in (memory, tracks):
            axis.axvline(frame, color="grey", lw=0.8, ls=":")
    memory.set_title("The localization over the highway clip played again and again")
    fig.tight_layout()
    with atomic_path(path) as temporary:
        fig.savefig(temporary, format="png", dpi=110)
    plt.close(fig)
    return path


@exit_on_error("experiments/benchmarks/memory_loop.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calibration", type=Path, required=True, help="calibration.json of the highway clip")
    parser.add_argument("--model", type=Path, required=True, help="an ONNX classifier written by vehloc-export")
    parser.add_argument("--out", type=Path, default=Path("outputs/bench_memory"))
    parser.add_argument("--passes", type=int, default=3)
    parser.add_argument("--every", type=int, default=50, help="frames between samples")
    args = parser.parse_args()
    if args.passes < 2 or args.every < 1:
        parser.error("--passes must be at least 2 and --every at least 1")
    localizer = Localizer(VehicleClassifier.from_onnx(args.model), read_calibration(args.calibration),
                          LocalizeSettings.compose([EXPERIMENT]))
    samples = run(localizer, args.passes, args.every)
    ends = samples[samples["end_of_pass"]].reset_index(drop=True)
    first = float(ends.loc[0, "rss_mib"])
    ends["growth_since_first_pct"] = 100.0 * (ends["rss_mib"] / first - 1.0)
    growth = float(ends["growth_since_first_pct"].iloc[-1])
    cpu = cpu_info()
    lines = [f"# The localization's memory over the highway clip, {args.passes} passes", "",
             f"CPU: {cpu.describe()}; model {args.model.name}; the clip's settings `{EXPERIMENT}`.", "",
             markdown_table(ends[["pass", "frame", "records", "tracks_started", "tracks_held", "rss_mib",
                                   "growth_since_first_pct"]],
                            "{:.1f}"), "",
             f"Most tracks held at once: {int(samples['tracks_held'].max())}. After the last pass the resident memory "
             f"is {growth:+.1f} % of that after the first (at most {100 * MAX_GROWTH:.0f} %): "
             f"**{'met' if growth <= 100 * MAX_GROWTH else 'not met'}**.", ""]
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "memory.csv", samples.to_csv(index=False, float_format="%.2f"))
    write_text(args.out / "memory.md", "\n".join(lines))
    figure(samples, args.out / "memory.png")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
