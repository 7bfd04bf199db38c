"""Train-step time of GoogLeNet from scratch (aux heads, `experiment=demo_googlenet_scratch`'s batch and input size) in
fp32 and under CPU bf16 autocast, each with and without channels-last weights, measured side by side in one
run, with the CPU's model name and flags; and the precision that `trainer.precision=auto` picks here.

    .venv/bin/python experiments/bench_precision.py --out outputs/bench_precision
    .venv/bin/python experiments/bench_precision.py --out outputs/bench_precision_lite0 model=efficientnet_lite0 \
        model.backbone.pretrained=none data.input_size_px=112 data.batch_size=16 model.frozen_blocks=5   # the demo's

One step is forward (+ GoogLeNet's auxiliary heads), loss, backward and a step of the experiment's optimizer on a fixed
random batch.
Variants alternate within each round (fp32, fp32 + channels-last, bf16, bf16 + channels-last, ...) so that
a slow spell of the machine hits all of them; the median over rounds is reported, the best beside it.
Writes `precision.csv` and `precision.md` into `--out`.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import torch
from omegaconf import OmegaConf

from vehloc.config import build_params
from vehloc.hardware import cpu_info
from vehloc.train.instantiate import compose_config
from vehloc.train.module import LitVehicleClassifier
from vehloc.train.params import ModelParams
from vehloc.train.precision import resolve_precision
from vehloc.tables import markdown_table
from vehloc.train.schedules import build_optimizer, param_groups
from vehloc.errors import exit_on_error

DEMO_CLASSES = 12


@dataclass(frozen=True)
class Variant:
    name: str
    bf16_autocast: bool
    channels_last: bool


VARIANTS = (
    Variant("fp32", False, False),
    Variant("fp32 + channels-last", False, True),
    Variant("bf16 autocast", True, False),
    Variant("bf16 autocast + channels-last", True, True),
)


def build_model(model: ModelParams, channels_last: bool) -> LitVehicleClassifier:
    """The experiment's model (GoogLeNet unless overridden) for 12 classes, from scratch (seed 0: every variant
    starts alike)."""
    torch.manual_seed(0)
    table = {"class_model_ids": list(range(1, DEMO_CLASSES + 1)), "class_makes": ["make"] * DEMO_CLASSES,
             "class_models": [f"model {i}" for i in range(DEMO_CLASSES)],
             "class_dims_mm": [[4500.0, 1800.0, 1450.0]] * DEMO_CLASSES}
    return LitVehicleClassifier.from_params(dataclasses.replace(model, channels_last=channels_last), **table)


def step_seconds(model: LitVehicleClassifier, optimizer: torch.optim.Optimizer, batch: tuple, bf16_autocast: bool,
                 steps: int) -> list[float]:
    """Wall time of each of `steps` training steps on `batch`."""
    model.train()
    times = []
    for _ in range(steps):
        start_s = time.perf_counter()
        autocast = torch.autocast("cpu", dtype=torch.bfloat16) if bf16_autocast else contextlib.nullcontext()
        with autocast:
            loss = model.model_step(batch)[0]
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        times.append(time.perf_counter() - start_s)
    return times


@exit_on_error("experiments/bench_precision.py")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("outputs/bench_precision"))
    parser.add_argument("--steps", type=int, default=4, help="timed steps per variant and round")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--warmup", type=int, default=2, help="untimed steps per variant before the rounds")
    parser.add_argument("overrides", nargs="*",
                        help="Hydra overrides of conf/train.yaml (after experiment=demo_googlenet_scratch)")
    args = parser.parse_args(argv)

    cfg = compose_config("train", ["experiment=demo_googlenet_scratch", "data.root=unused", *args.overrides], args.out)
    batch_size, size_px = int(cfg.data.batch_size), int(cfg.data.input_size_px)
    generator = torch.Generator().manual_seed(0)
    batch = (torch.rand(batch_size, 3, size_px, size_px, generator=generator),
             torch.randint(0, DEMO_CLASSES, (batch_size,), generator=generator))
    cpu = cpu_info()
    auto = resolve_precision("auto", "cpu", cpu)
    print(f"CPU: {cpu.describe()}; torch {torch.__version__}, {torch.get_num_threads()} threads, "
          f"capability {torch.backends.cpu.get_cpu_capability()}")
    print(f"trainer.precision=auto picks {auto.resolved} here: {auto.reason}")

    runs = {}
    model_params = build_params(ModelParams, OmegaConf.to_container(cfg.model, resolve=True), "model")
    for variant in VARIANTS:
        model = build_model(model_params, variant.channels_last)
        opt = dict(model.hparams.optimizer)
        groups = param_groups(model.named_parameters(), model.head_prefixes, opt.pop("lr_backbone"),
                              opt.pop("lr_head"), opt.pop("weight_decay", 0.0), model.hparams.layer_decay)
        optimizer = build_optimizer(groups, **opt)
        step_seconds(model, optimizer, batch, variant.bf16_autocast, args.warmup)
        runs[variant] = (model, optimizer, [])
    for round_index in range(args.rounds):
        for variant, (model, optimizer, times) in runs.items():
            times += step_seconds(model, optimizer, batch, variant.bf16_autocast, args.steps)
        print(f"round {round_index + 1}/{args.rounds}: "
              + ", ".join(f"{v.name} {statistics.median(t[-args.steps:]):.3f} s" for v, (_, _, t) in runs.items()))

    fp32_s = statistics.median(runs[VARIANTS[0]][2])
    demo_channels_last = bool(cfg.model.channels_last)
    rows = []
    for variant, (_, _, times) in runs.items():
        median_s = statistics.median(times)
        is_demo = variant.channels_last == demo_channels_last and variant.bf16_autocast == (auto.resolved == "bf16-mixed")
        rows.append({"variant": variant.name, "step_s_median": median_s, "step_s_best": min(times),
                     "images_per_s": batch_size / median_s, "vs_fp32": median_s / fp32_s,
                     "demo_auto": "yes" if is_demo else ""})
    frame = pd.DataFrame(rows)
    setup = (f"GoogLeNet (aux heads) from scratch, {DEMO_CLASSES} classes, batch {batch_size}, {size_px} px, AdamW; "
             f"{args.rounds} rounds x {args.steps} timed steps per variant after {args.warmup} warm-up steps; "
             f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    lines = [
        "# Train-step time by precision", "",
        f"CPU: {cpu.describe()}.", "",
        setup + ".", "",
        f"`trainer.precision=auto` picks **{auto.resolved}** on this CPU ({auto.reason}); the demo experiment "
        f"uses channels-last = {demo_channels_last}: its row is marked under demo_auto.", "",
        markdown_table(frame, "{:.3f}"), "",
        "vs_fp32: median step time over that of plain fp32 (NCHW) in the same run.",
    ]
    args.out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(args.out / "precision.csv", index=False, float_format="%.4f")
    (args.out / "precision.md").write_text("\n".join(lines) + "\n")
    print(frame.to_string(index=False))
    print(f"wrote {args.out / 'precision.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
