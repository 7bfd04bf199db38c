"""The randomized localization benchmark: seeded cases drawn over the catalog's models, colours, poses,
cameras and light (`cases`), what of each car a camera can see (`visibility`), one case rendered and
localized against its truth (`runner`), and the per-group rates, tables and figures (`report`)."""

from vehloc.benchmark.cases import BenchmarkCase, draw_case
from vehloc.benchmark.oracle import TrueModelClassifier
from vehloc.benchmark.report import write_report
from vehloc.benchmark.runner import CaseOutcome, run_case
from vehloc.benchmark.suite import BenchmarkSettings, run_benchmark
from vehloc.benchmark.visibility import Visibility, VisibilityParams

__all__ = [
    "BenchmarkCase", "BenchmarkSettings", "CaseOutcome", "TrueModelClassifier", "Visibility", "VisibilityParams",
    "draw_case", "run_benchmark", "run_case", "write_report",
]
