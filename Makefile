# Two commands: `make run` and `make test`. Both create/refresh the virtualenv in .venv.
PYTHON ?= python3
VENV := .venv
VENV4 := .venv-mavsdk4
STAMP := $(VENV)/.installed
STAMP4 := $(VENV4)/.installed
VEHICLES ?= 1
PYTEST_ARGS ?=

.PHONY: run test unit bench clean venv

venv: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -e '.[test]'
	touch $@

# MAVSDK 4.x (native binding) cannot share a venv with mavsdk<4: its end-to-end test runs
# a client script in this second venv through a subprocess.
$(STAMP4): pyproject.toml
	$(PYTHON) -m venv $(VENV4)
	$(VENV4)/bin/pip install --quiet --upgrade pip
	$(VENV4)/bin/pip install --quiet 'mavsdk>=4'
	touch $@

run: $(STAMP)
	$(VENV)/bin/cornet run --vehicles $(VEHICLES)

test: $(STAMP) $(STAMP4)
	CORNET_MAVSDK4_PYTHON=$(CURDIR)/$(VENV4)/bin/python $(VENV)/bin/python -m pytest $(PYTEST_ARGS)

unit: $(STAMP)
	$(VENV)/bin/python -m pytest tests/unit $(PYTEST_ARGS)

bench: $(STAMP)
	$(VENV)/bin/python bench/realtime.py

clean:
	rm -rf $(VENV) $(VENV4) *.egg-info .pytest_cache
