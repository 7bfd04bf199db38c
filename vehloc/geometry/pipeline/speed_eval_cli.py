"""`vehloc-speed-eval RESULTS GT --out DIR`: score a speed results file (`system_*.json`, as `vehloc-localize` writes
it) against a video's ground truth (BrnoCompSpeed's `gt_data.pkl`, or the same fields as JSON, as `vehloc-scene`
writes it for a traffic scene) with the benchmark's rules, and write the matches, the summary and its plot."""

from __future__ import annotations

from pathlib import Path

from vehloc.atomic import check_output_dir
from vehloc.config import ArgumentParser, positive_number_argument
from vehloc.errors import VehlocError, exit_on_error
from vehloc.geometry.pipeline.brno_files import BrnoFileError, read_ground_truth, read_results
from vehloc.geometry.pipeline.speed_eval import BENCHMARK_SIZE_PX, MODES, score_speeds
from vehloc.geometry.pipeline.speed_report import write_score

FPS_TOLERANCE = 1e-3


def check_same_video(results_path: Path, results_video: str | None, truth_path: Path, truth_video: str | None) -> None:
    """BrnoFileError when both files name their video and the names differ."""
    if results_video and truth_video and Path(results_video).resolve() != Path(truth_video).resolve():
        raise BrnoFileError(f"{results_path}: results of {results_video}, but {truth_path} is the truth of {truth_video}")


@exit_on_error("vehloc-speed-eval")
def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="vehloc-speed-eval", description=__doc__)
    parser.add_argument("results", type=Path, help="a system's results file (system_vehloc.json of vehloc-localize)")
    parser.add_argument("truth", type=Path, help="the video's ground truth (gt_data.pkl or gt_data.json)")
    parser.add_argument("--out", type=Path, required=True, help="the folder to write the score into")
    parser.add_argument("--mode", choices=MODES, default="median",
                        help="a car's speed: the median over 5-frame steps (the benchmark's default) or between the lines")
    parser.add_argument("--fps", type=positive_number_argument, default=None,
                        help="the video's frame rate, checked against the truth's (default: the results file's, if given)")
    args = parser.parse_args(argv)
    truth = read_ground_truth(args.truth)
    results = read_results(args.results)
    check_same_video(args.results, results.video, args.truth, truth.video)
    fps = args.fps if args.fps is not None else results.fps
    if fps is not None and abs(fps - truth.fps) > FPS_TOLERANCE:
        raise BrnoFileError(f"{args.truth}: fps is {truth.fps:g}, the video's is {fps:g}")
    out_dir = check_output_dir(args.out, "--out")
    try:
        score = score_speeds(results, truth, results.image_size_px or BENCHMARK_SIZE_PX, args.mode)
    except ValueError as err:
        raise VehlocError(f"{args.results}: {err}") from None
    summary = write_score(score, out_dir, f"Speeds of {args.results.name} against {args.truth.name}")
    print(f"{summary['measured']:.0f} of {summary['true_cars']:.0f} true cars measured: mean / median speed error "
          f"{summary['mean_error_kmh']:.2f} / {summary['median_error_kmh']:.2f} km/h, recall {summary['recall']:.3f}, "
          f"precision {summary['precision']:.3f}: {out_dir / 'speed_eval.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
