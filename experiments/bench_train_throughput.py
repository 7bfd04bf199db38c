"""Training throughput of the workbench (Lightning Trainer + LitVehicleClassifier) against a plain PyTorch loop
over the same model, batches and optimizer, and the data loader's images/s against the model's.

    .venv/bin/python experiments/bench_train_throughput.py --out outputs/bench_train_throughput \
        experiment=demo data.root=demo_data/compcars

Both loops consume the same batches, prepared once and held in memory, so that the comparison measures the
training framework alone; the data loader is timed on its own. Runs alternate (plain, workbench, plain, ...);
the best of `--repeats` is reported (other processes only ever slow a run down), the median beside it.
Writes `throughput.csv`, `ratios.csv` and `throughput.md` into `--out`.
"""

from __future__ import annotations

import argparse
import copy
import statistics
import sys
import time
from pathlib import Path

import lightning as L
import pandas as pd
import torch
from torch.utils.data import DataLoader, Dataset

from vehloc.train.params import check_train_config
from vehloc.train.instantiate import compose_config, instantiate_data_and_model
from vehloc.train.module import LitVehicleClassifier
from vehloc.tables import markdown_table
from vehloc.train.schedules import build_optimizer, param_groups
from vehloc.errors import exit_on_error


class BatchList(Dataset):
    """Ready-made batches, served one per item (use with `batch_size=None`)."""

    def __init__(self, batches: list) -> None:
        self.batches = batches

    def __len__(self) -> int:
        return len(self.batches)

    def __getitem__(self, index: int):
        return self.batches[index]


class StepTimer(L.Callback):
    """Wall time from the start of batch `warmup` to the end of the last batch."""

    def __init__(self, warmup: int) -> None:
        self.warmup = warmup
        self.start_s = self.end_s = 0.0

    def on_train_batch_start(self, trainer, pl_module, batch, batch_idx) -> None:
        if batch_idx == self.warmup:
            self.start_s = time.perf_counter()

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        self.end_s = time.perf_counter()


def loader_images_per_s(loader: DataLoader, batches: int) -> tuple[float, list]:
    """Images/s of the data loader alone over `batches` batches (after the first, across epochs as needed),
    and the batches it made."""
    kept: list = []
    images = 0
    start_s = 0.0
    while len(kept) <= batches:
        for batch in loader:
            if not kept:
                start_s = time.perf_counter()
            else:
                images += len(batch[0])
            kept.append(batch)
            if len(kept) > batches:
                break
    return images / (time.perf_counter() - start_s), kept[1:]


def plain_images_per_s(model: LitVehicleClassifier, loader: DataLoader, warmup: int, optim_cfg: dict) -> float:
    """A hand-written loop: model_step, backward, optimizer step, per batch."""
    opt = dict(optim_cfg)
    groups = param_groups(model.named_parameters(), model.head_prefixes, opt.pop("lr_backbone"),
                          opt.pop("lr_head"), opt.pop("weight_decay", 0.0))
    optimizer = build_optimizer(groups, **opt)
    model.train()
    images = 0
    start_s = 0.0
    for index, batch in enumerate(loader):
        if index == warmup:
            start_s = time.perf_counter()
        loss = model.model_step(batch)[0]
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        if index >= warmup:
            images += len(batch[0])
    return images / (time.perf_counter() - start_s)


def workbench_images_per_s(model: LitVehicleClassifier, loader: DataLoader, warmup: int) -> float:
    """The workbench's training loop: Lightning Trainer + LitVehicleClassifier (metrics, schedule, progress bar)."""
    timer = StepTimer(warmup)
    trainer = L.Trainer(
        accelerator="cpu", devices=1, max_epochs=1, limit_val_batches=0, num_sanity_val_steps=0,
        enable_checkpointing=False, logger=False, enable_model_summary=False, callbacks=[timer],
    )
    trainer.fit(model, train_dataloaders=loader)
    images = sum(len(b[0]) for b in loader.dataset.batches[warmup:])
    return images / (timer.end_s - timer.start_s)


@exit_on_error("experiments/bench_train_throughput.py")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("outputs/bench_train_throughput"))
    parser.add_argument("--batches", type=int, default=20, help="timed batches per run")
    parser.add_argument("--warmup", type=int, default=2, help="untimed batches at the start of each run")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("overrides", nargs="*", help="Hydra overrides of conf/train.yaml")
    args = parser.parse_args(argv)

    cfg = compose_config("train", ["experiment=demo", *args.overrides], args.out)
    torch.manual_seed(0)
    datamodule, model = instantiate_data_and_model(*check_train_config(cfg))
    datamodule.setup("fit")
    loader_rate, batches = loader_images_per_s(datamodule.train_dataloader(), args.warmup + args.batches)
    served = DataLoader(BatchList(batches), batch_size=None, shuffle=False)
    initial = copy.deepcopy(model.state_dict())
    optim_cfg = dict(cfg.model.optimizer)

    plain, workbench = [], []
    for _ in range(args.repeats):
        model.load_state_dict(initial)
        plain.append(plain_images_per_s(model, served, args.warmup, optim_cfg))
        model.load_state_dict(initial)
        workbench.append(workbench_images_per_s(model, served, args.warmup))

    plain_rate, workbench_rate = max(plain), max(workbench)
    batch_size = len(batches[0][0])
    input_px = tuple(batches[0][0].shape[-2:])
    rows = [
        {"measure": "data loader (decode, ROI crop, augment)", "images_per_s": loader_rate,
         "runs": 1, "note": f"num_workers={cfg.data.num_workers}"},
        {"measure": "plain PyTorch loop", "images_per_s": plain_rate, "runs": args.repeats,
         "note": "runs: " + " ".join(f"{v:.1f}" for v in plain)},
        {"measure": "workbench (Lightning Trainer + module)", "images_per_s": workbench_rate, "runs": args.repeats,
         "note": "runs: " + " ".join(f"{v:.1f}" for v in workbench)},
    ]
    ratios = [
        {"ratio": "workbench / plain loop (best runs)", "value": workbench_rate / plain_rate, "target": ">= 0.95"},
        {"ratio": "workbench / plain loop (median runs)",
         "value": statistics.median(workbench) / statistics.median(plain), "target": ">= 0.95"},
        {"ratio": "data loader / model (plain loop)", "value": loader_rate / plain_rate,
         "target": "> 1: the loader keeps up"},
    ]
    args.out.mkdir(parents=True, exist_ok=True)
    frame, ratio_frame = pd.DataFrame(rows), pd.DataFrame(ratios)
    frame.to_csv(args.out / "throughput.csv", index=False, float_format="%.3f")
    ratio_frame.to_csv(args.out / "ratios.csv", index=False, float_format="%.3f")
    setup = (f"backbone {cfg.model.backbone.name}, batch {batch_size}, input {input_px[0]}x{input_px[1]} px, "
             f"{args.batches} timed batches after {args.warmup} warm-up, best of {args.repeats} alternating runs, "
             f"torch threads {torch.get_num_threads()}")
    (args.out / "throughput.md").write_text(
        "# Training throughput\n\n" + setup + "\n\n" + markdown_table(frame, "{:.1f}") + "\n\n"
        + markdown_table(ratio_frame, "{:.3f}") + "\n"
    )
    print(setup)
    print(frame.to_string(index=False))
    print(ratio_frame.to_string(index=False))
    print(f"wrote {args.out / 'throughput.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
