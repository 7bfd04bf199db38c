"""The workbench recipe against a plain PyTorch loop, same data, same backbone, same wall-clock budget, in one
run: first `vehloc-train experiment=<recipe>` (its whole run timed: training, validation, test, Table 1), then
a hand-written loop given that time to train (AdamW, one-cycle over the budget, label smoothing, 224 px, no
validation), tested on the same test split. Writes plain_loop_vs_recipe.csv / .md into --out.

    .venv/bin/python experiments/benchmarks/plain_loop_vs_recipe.py --out outputs/plain_vs_recipe
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import torch
import torch.nn.functional as F
from PIL import Image
from torch.utils.data import DataLoader, Dataset
from torchvision import transforms as T

from vehloc.atomic import write_text
from vehloc.hardware import cpu_info
from vehloc.tables import markdown_table
from vehloc.train.efficientnet_lite import LITE_MEAN, LITE_STD, EfficientNetLite, lite_weights_path
from vehloc.errors import exit_on_error

PROJECT_ROOT = Path(__file__).resolve().parents[2]


# ---- the plain loop: what a researcher writes by hand in ~70 lines ----
class CarCrops(Dataset):
    """A CompCars-format split: the labelled box of each image, the model id's index as its class."""

    def __init__(self, root: Path, split: str, transform: T.Compose, classes: list[str] | None = None) -> None:
        self.root, self.transform = root, transform
        self.items = (root / "train_test_split" / "classification" / f"{split}.txt").read_text().split()
        self.classes = classes or sorted({item.split("/")[1] for item in self.items}, key=int)

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, index: int) -> tuple[torch.Tensor, int]:
        item = self.items[index]
        x1, y1, x2, y2 = map(int, (self.root / "label" / item).with_suffix(".txt").read_text().split()[2:6])
        image = Image.open(self.root / "image" / item).convert("RGB").crop((x1 - 1, y1 - 1, x2, y2))
        return self.transform(image), self.classes.index(item.split("/")[1])


def plain_loop(root: Path, budget_s: float, size_px: int = 224, max_lr: float = 1e-3) -> tuple[float, float, int]:
    """Train Lite0 from its ImageNet weights for `budget_s` seconds; (test top-1 %, seconds, epochs started)."""
    torch.manual_seed(0)
    normalize = T.Normalize(LITE_MEAN, LITE_STD)
    train_set = CarCrops(root, "train", T.Compose([
        T.RandomResizedCrop(size_px, scale=(0.6, 1.0)), T.RandomHorizontalFlip(), T.ColorJitter(0.2, 0.2, 0.2),
        T.ToTensor(), normalize]))
    test_set = CarCrops(root, "test", T.Compose([T.Resize((size_px, size_px)), T.ToTensor(), normalize]),
                        train_set.classes)
    net = EfficientNetLite("lite0")
    net.load_state_dict(torch.load(lite_weights_path("lite0"), map_location="cpu", weights_only=True))
    net._fc = torch.nn.Linear(net._fc.in_features, len(train_set.classes))
    optimizer = torch.optim.AdamW(net.parameters(), lr=max_lr, weight_decay=0.01)
    loader = DataLoader(train_set, batch_size=32, shuffle=True, num_workers=2, drop_last=True)
    start, epochs, done = time.perf_counter(), 0, False
    while not done:
        epochs += 1
        net.train()
        for images, labels in loader:
            progress = (time.perf_counter() - start) / budget_s
            if progress >= 1.0:
                done = True
                break
            # one-cycle over the budget: linear warm-up over its first 30 %, then cosine down to zero
            factor = progress / 0.3 if progress < 0.3 else 0.5 * (1 + math.cos(math.pi * (progress - 0.3) / 0.7))
            for group in optimizer.param_groups:
                group["lr"] = max_lr * max(factor, 0.04)
            loss = F.cross_entropy(net(images), labels, label_smoothing=0.1)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
        print(f"plain loop: epoch {epochs}, {time.perf_counter() - start:.0f} s of {budget_s:.0f}", flush=True)
    net.eval()
    correct = 0
    with torch.no_grad():
        for images, labels in DataLoader(test_set, batch_size=64, num_workers=2):
            correct += int((net(images).argmax(1) == labels).sum())
    return 100.0 * correct / len(test_set), time.perf_counter() - start, epochs
# ---- end of the plain loop ----


def workbench_recipe(experiment: str, overrides: list[str], out: Path) -> tuple[float, float]:
    """`vehloc-train experiment=<experiment>`: (test top-1 %, wall seconds of the whole run)."""
    command = [str(Path(sys.executable).parent / "vehloc-train"), f"experiment={experiment}", *overrides,
               f"hydra.run.dir={out / 'recipe'}", "logger=csv"]
    print(f"workbench: {' '.join(command[1:])}", flush=True)
    start = time.perf_counter()
    subprocess.run(command, cwd=PROJECT_ROOT, check=True)
    seconds = time.perf_counter() - start
    accuracy = pd.read_csv(out / "recipe" / "table1" / "accuracy.csv").set_index("metric")["value"]
    return float(accuracy["top1_pct"]), seconds


@exit_on_error("experiments/benchmarks/plain_loop_vs_recipe.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="run folder")
    parser.add_argument("--experiment", default="stanford_cars_12", help="the workbench recipe")
    parser.add_argument("--root", type=Path, default=PROJECT_ROOT.parent / "shared" / "data" / "stanford_cars_12")
    parser.add_argument("--overrides", nargs="*", default=[], help="more overrides of the workbench run")
    args = parser.parse_args()
    if not (args.root / "train_test_split").is_dir():
        raise SystemExit(f"plain_loop_vs_recipe: {args.root} is not a CompCars-format root (no train_test_split/)")
    args.out.mkdir(parents=True, exist_ok=True)
    recipe_top1, budget_s = workbench_recipe(args.experiment, [f"data.root={args.root}", *args.overrides], args.out)
    plain_top1, plain_s, epochs = plain_loop(args.root, budget_s)
    table = pd.DataFrame([
        {"method": f"workbench: experiment={args.experiment}", "test_top1_pct": recipe_top1,
         "wall_minutes": budget_s / 60, "note": "whole run: training, validation, test, Table 1"},
        {"method": "plain PyTorch loop (Lite0, 224 px, AdamW one-cycle, label smoothing)", "test_top1_pct": plain_top1,
         "wall_minutes": plain_s / 60, "note": f"trained for the workbench's whole time ({epochs} epochs begun)"},
    ])
    write_text(args.out / "plain_loop_vs_recipe.csv", table.to_csv(index=False, float_format="%.2f"))
    text = (f"# Workbench recipe vs a plain loop\n\n{args.root}, {cpu_info().describe()}\n\n{markdown_table(table)}\n\n"
            f"Workbench minus plain loop: {recipe_top1 - plain_top1:+.1f} points top-1.\n")
    write_text(args.out / "plain_loop_vs_recipe.md", text)
    print(text)


if __name__ == "__main__":
    main()
