# The two set-up commands of the README: `make demo` and `make test`.
# Each creates (or reuses) the virtual environment in .venv and installs vehloc into it.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
INSTALLED := $(VENV)/.installed
DEMO_DIR ?= demo_data

.PHONY: demo test test-fast install clean-demo

install: $(INSTALLED)

$(INSTALLED): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(INSTALLED)

demo: $(INSTALLED)
	$(BIN)/vehloc-data make-demo $(DEMO_DIR)/compcars --per-model 240 --seed 0
	$(BIN)/vehloc-data check $(DEMO_DIR)/compcars
	$(BIN)/vehloc-data contact-sheet $(DEMO_DIR)/compcars $(DEMO_DIR)/contact_sheet.png
	$(BIN)/vehloc-train experiment=demo data.root=$(DEMO_DIR)/compcars hydra.run.dir=$(DEMO_DIR)/train
	$(BIN)/vehloc-export ckpt_path=$(DEMO_DIR)/train/checkpoints/last.ckpt data_root=$(DEMO_DIR)/compcars \
		output=$(DEMO_DIR)/model.onnx hydra.run.dir=$(DEMO_DIR)/export
	$(BIN)/vehloc-predict --model $(DEMO_DIR)/model.onnx --top-k 3 --compcars-labels \
		$$(head -n 2 $(DEMO_DIR)/compcars/train_test_split/classification/test.txt | sed 's|^|$(DEMO_DIR)/compcars/image/|')

test: $(INSTALLED)
	$(BIN)/python -m pytest

test-fast: $(INSTALLED)
	$(BIN)/python -m pytest -m "not slow"

clean-demo:
	rm -rf $(DEMO_DIR)
