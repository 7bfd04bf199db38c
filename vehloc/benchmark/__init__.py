"""The randomized localization benchmark: seeded cases drawn over the catalog's models, colours, poses,
cameras and light (`cases`), what of each car a camera can see (`visibility`), one case rendered and
localized against its truth (`runner`), the per-group rates, tables and figures (`report`), and a real video's
records against truth read by hand (`spot_truth`: fronts in single frames, `crossings`: vehicles through a row)."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "cases": ["BenchmarkCase", "draw_case"],
    "crossings": ["Crossing", "CrossingCount", "CrossingMatch", "match_crossings", "read_crossings"],
    "oracle": ["TrueModelClassifier"],
    "report": ["write_report"],
    "runner": ["CaseOutcome", "run_case"],
    "spot_truth": ["Spot", "SpotCheck", "SpotTruth", "check_spot", "read_spot_truth", "spot_table"],
    "suite": ["BenchmarkSettings", "run_benchmark"],
    "visibility": ["Visibility", "VisibilityParams"],
})
