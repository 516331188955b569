# Two commands: `make run` and `make test`. Both create/refresh the virtualenv in .venv.
PYTHON ?= python3
VENV := .venv
VENV4 := .venv-mavsdk4
STAMP := $(VENV)/.installed
STAMP4 := $(VENV4)/.installed
VEHICLES ?= 1
PYTEST_ARGS ?=

.PHONY: run test unit bench clean venv ns3 ns3-deps ns3-if-possible

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

test: $(STAMP) $(STAMP4) ns3-if-possible
	CORNET_MAVSDK4_PYTHON=$(CURDIR)/$(VENV4)/bin/python $(VENV)/bin/python -m pytest $(PYTEST_ARGS)

unit: $(STAMP)
	$(VENV)/bin/python -m pytest tests/unit $(PYTEST_ARGS)

bench: $(STAMP)
	$(VENV)/bin/python bench/realtime.py

# The real ns-3 backend (netsim/ns3/): `make ns3` builds netsim/ns3/build/cornet-ns3 against
# Debian's ns-3 3.37; `make ns3-deps` installs what that needs where apt exists (as root).
NS3_DEBS := libns3-dev libzmq3-dev cppzmq-dev libgsl-dev pkg-config g++

ns3:
	$(MAKE) -C netsim/ns3 -j2

ns3-deps:
	@if dpkg -s $(NS3_DEBS) >/dev/null 2>&1; then echo "ns3-deps: $(NS3_DEBS) already installed"; \
	elif ! command -v apt-get >/dev/null; then \
		echo "ns3-deps: no apt-get here; install ns-3 3.37 development files ($(NS3_DEBS)) by hand"; exit 1; \
	else apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y $(NS3_DEBS); fi

# `make test` builds the ns-3 backend where it can (the packages there, or apt as root); where it
# cannot, the ns-3 tests skip and say what is missing.
ns3-if-possible:
	@if dpkg -s $(NS3_DEBS) >/dev/null 2>&1 || { command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ]; }; then \
		$(MAKE) ns3-deps ns3 || echo "note: the ns-3 backend was not built; its tests will skip"; \
	else echo "note: no apt-get as root here: the ns-3 backend is not built; its tests will skip"; fi

clean:
	rm -rf $(VENV) $(VENV4) *.egg-info .pytest_cache
