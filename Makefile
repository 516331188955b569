# Two commands: `make run` and `make test`. Both create/refresh the virtualenv in .venv.
# `make run VEHICLES=3 PORT_OFFSET=100`: three vehicles, every port shifted by 100.
PYTHON ?= python3
VENV := .venv
VENV4 := .venv-mavsdk4
VENVG := .venv-mavsdk-grpc
STAMP := $(VENV)/.installed
STAMP4 := $(VENV4)/.installed
STAMPG := $(VENVG)/.installed
VEHICLES ?= 1
PORT_OFFSET ?= 0
# What clients change (parameters, mission, geofence) and the flight logs, kept across runs as a
# PX4 SITL instance keeps them in its rootfs: `make run STATE_DIR=elsewhere`.
STATE_DIR ?= state
PYTEST_ARGS ?=
# Three pytest workers that steal work from each other: xdist's default hands each worker a first
# chunk of consecutive tests, so one worker would run every end-to-end test in a row. Tests marked
# `solo` (real-time ns-3 flights that need the CPU to themselves) run afterwards, one at a time.
# pytest's exit status 5 (nothing collected, e.g. a -k that selects no solo test) is not a failure.
PYTEST_WORKERS ?= 3

.PHONY: run test unit typecheck bench clean venv ns3 ns3-deps ns3-if-possible browser-if-possible \
	install-service

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

# MAVSDK-Python's gRPC wrapper as published from 4.0 on, `mavsdk-grpc` (import mavsdk_grpc,
# mavsdk_server v4): a third venv, for the same reason.
$(STAMPG): pyproject.toml
	$(PYTHON) -m venv $(VENVG)
	$(VENVG)/bin/pip install --quiet --upgrade pip
	$(VENVG)/bin/pip install --quiet 'mavsdk-grpc>=4,<5'
	touch $@

run: $(STAMP)
	$(VENV)/bin/cornet run --vehicles $(VEHICLES) --port-offset $(PORT_OFFSET) --state-dir $(STATE_DIR)

test: $(STAMP) $(STAMP4) $(STAMPG) ns3-if-possible browser-if-possible
	$(VENV)/bin/mypy
	CORNET_MAVSDK4_PYTHON=$(CURDIR)/$(VENV4)/bin/python \
	CORNET_MAVSDK_GRPC_PYTHON=$(CURDIR)/$(VENVG)/bin/python \
		$(VENV)/bin/python -m pytest -n $(PYTEST_WORKERS) --dist worksteal -m 'not solo' $(PYTEST_ARGS) \
		|| [ $$? = 5 ]
	CORNET_MAVSDK4_PYTHON=$(CURDIR)/$(VENV4)/bin/python \
	CORNET_MAVSDK_GRPC_PYTHON=$(CURDIR)/$(VENVG)/bin/python \
		$(VENV)/bin/python -m pytest -m solo $(PYTEST_ARGS) || [ $$? = 5 ]

typecheck: $(STAMP)
	$(VENV)/bin/mypy

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

# The live view's browser test (tests/e2e/test_web.py) drives Debian's chromium through its
# chromedriver (Selenium, in the test extra): installed with apt where we are root; elsewhere
# that test skips and names what is missing.
BROWSER_DEBS := chromium chromium-driver

browser-if-possible:
	@if dpkg -s $(BROWSER_DEBS) >/dev/null 2>&1; then echo "browser: $(BROWSER_DEBS) already installed"; \
	elif command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ]; then \
		{ apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y $(BROWSER_DEBS); } \
		|| echo "note: $(BROWSER_DEBS) were not installed; the live view's browser test will skip"; \
	else echo "note: no apt-get as root here: $(BROWSER_DEBS) are not installed; the live view's browser test will skip"; fi

# `sudo make install-service`: the daemon as a systemd service (README.md, "Running as a service").
# Copies this tree (without .git, virtualenvs or build output) to $(PREFIX) and builds a venv there
# with a regular, non-editable install with the live view's [web] extra (a venv cannot move, and
# the service may not read /home);
# installs the unit, and $(CONFIG_DIR)/cornet.toml only if there is none: an existing
# configuration is never overwritten. Needs root, and PyPI (or a pip cache) for the venv.
# PREFIX, CONFIG_DIR and UNIT_DIR may be changed (the unit's paths follow PREFIX and CONFIG_DIR).
PREFIX ?= /opt/cornet
CONFIG_DIR ?= /etc/cornet
UNIT_DIR ?= /etc/systemd/system

install-service:
	@[ "$$(id -u)" = 0 ] || { echo "install-service: needs root: sudo make install-service"; exit 1; }
	mkdir -p $(PREFIX)
	tar -c --exclude=./.git --exclude=./.venv --exclude=./.venv-mavsdk4 --exclude=./.venv-mavsdk-grpc \
		--exclude=__pycache__ \
		--exclude=./.pytest_cache --exclude='*.egg-info' --exclude=./build --exclude=./state \
		--exclude=./logs -f - . | tar -x --no-same-owner -C $(PREFIX)
	$(PYTHON) -m venv $(PREFIX)/.venv
	$(PREFIX)/.venv/bin/pip install --quiet --upgrade pip
	$(PREFIX)/.venv/bin/pip install --quiet '$(PREFIX)[web]'
	mkdir -p $(UNIT_DIR)
	sed -e 's#/opt/cornet#$(PREFIX)#g' -e 's#/etc/cornet/cornet.toml#$(CONFIG_DIR)/cornet.toml#g' \
		systemd/cornet.service > $(UNIT_DIR)/cornet.service
	@if [ -e $(CONFIG_DIR)/cornet.toml ]; then \
		echo "install-service: keeping $(CONFIG_DIR)/cornet.toml (the example: $(PREFIX)/systemd/cornet.toml)"; \
	else install -D -m 0644 systemd/cornet.toml $(CONFIG_DIR)/cornet.toml; fi
	$(PREFIX)/.venv/bin/cornet check $(CONFIG_DIR)/cornet.toml
	@if [ -d /run/systemd/system ]; then systemctl daemon-reload; \
	else echo "install-service: systemd is not running here; run 'systemctl daemon-reload' where it is"; fi
	@echo "install-service: done; start it with: systemctl enable --now cornet"

clean:
	rm -rf $(VENV) $(VENV4) $(VENVG) *.egg-info .pytest_cache
