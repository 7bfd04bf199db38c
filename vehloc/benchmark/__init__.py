"""The randomized localization benchmark: seeded cases drawn over the catalog's models, colours, poses,
cameras and light (`cases`), what of each car a camera can see (`visibility`), one case rendered and
localized against its truth (`runner`), the per-group rates, tables and figures (`report`), two runs of the same
cases compared case by case (`paired`, written by `paired_report`), and a real video's
records against truth read by hand (`spot_truth`: fronts in single frames, `crossings`: vehicles through a row)."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "cases": ["BenchmarkCase", "draw_case"],
    "crossings": ["Crossing", "CrossingCount", "CrossingMatch", "match_crossings", "read_crossings"],
    "oracle": ["TrueModelClassifier"],
    "paired": ["Comparison", "GateChange", "compare_runs", "read_cases"],
    "paired_report": ["write_comparison"],
    "report": ["write_report"],
    "runner": ["CaseOutcome", "run_case"],
    "spot_truth": ["Spot", "SpotCheck", "SpotTruth", "check_spot", "read_spot_truth", "spot_table"],
    "suite": ["BenchmarkSettings", "run_benchmark"],
    "visibility": ["Visibility", "VisibilityParams"],
})
