"""The randomized localization benchmark: seeded cases drawn over the catalog's models, colours, poses,
cameras and light (`cases`), what of each car a camera can see (`visibility`), one case rendered and
localized against its truth (`runner`), and the per-group rates, tables and figures (`report`)."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "cases": ["BenchmarkCase", "draw_case"],
    "oracle": ["TrueModelClassifier"],
    "report": ["write_report"],
    "runner": ["CaseOutcome", "run_case"],
    "suite": ["BenchmarkSettings", "run_benchmark"],
    "visibility": ["Visibility", "VisibilityParams"],
})
