# Two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export RMW_IMPLEMENTATION ?= rmw_fastrtps_cpp

.PHONY: install interfaces browser test test-long demo bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)

$(STAMP): $(PY) setup.py setup.cfg package.xml lab/setup.py
	$(PY) -m pip install -e '.[ros,test,interfaces]' -e ./lab   # the product, and beside it the lab (benchmarks, fault suites, sweeps)
	$(VENV)/bin/iguana warm   # compile the kernels and cache the model once, not in four processes at the first run
	touch $(STAMP)

# The interface packages of interfaces/ (tf2_msgs, which no wheel carries, and iguana_interfaces), built with CMake
# and the rosidl generators of the `interfaces` extra and installed into the venv beside the ROS wheels: nothing
# to source at run time. About half a minute on two cores; again whenever interfaces/ or the script change.
IFACES_STAMP := $(VENV)/.interfaces-stamp
$(IFACES_STAMP): $(STAMP) tools/build_interfaces.py $(shell find interfaces -type f 2>/dev/null)
	$(PY) tools/build_interfaces.py
	touch $(IFACES_STAMP)

interfaces: $(IFACES_STAMP)

install: $(STAMP) $(IFACES_STAMP) browser

# Debian's Chromium and ChromeDriver for the browser tests of `iguana view` (skipped, saying why, without them).
browser:
	@if command -v chromium >/dev/null && command -v chromedriver >/dev/null; then :; \
	elif command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ]; then \
		{ apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium chromium-driver; } || \
		echo "make: apt-get could not install chromium and chromium-driver; the browser tests will be skipped"; \
	else echo "make: chromium and chromedriver are missing and cannot be installed here; the browser tests will be skipped"; fi

# Two pytest workers (pytest-xdist), a module per worker at a time so module-scoped runs are shared; each worker
# has its own ROS_DOMAIN_ID (test/conftest.py). `make test PYTEST_WORKERS=0` runs in one process.
PYTEST_WORKERS ?= 2
# `make test` leaves out the tests marked `long` (paper experiments, sweep engine, process and bag fault suites,
# cold-cache determinism, examples driving a run, ...), which `make test-long` runs; .ci/run runs both.
PYTEST := $(PY) -m pytest -q --durations=15 $(if $(filter 0,$(PYTEST_WORKERS)),,-n $(PYTEST_WORKERS) --dist loadscope)
# `iguana warm` first: after an edit of a kernel's source the package's cached kernels are stale, and processes of the
# run compiling them at once rounded differently from those that loaded them (10 node-vs-library bit-equality tests
# failed so); warm compiles them together in one process (~2 s when they are current).
test: $(STAMP) $(IFACES_STAMP) browser
	$(VENV)/bin/iguana warm
	$(PYTEST) -m 'not long'

test-long: $(STAMP) $(IFACES_STAMP)
	$(VENV)/bin/iguana warm
	$(PYTEST) -m long

demo: $(STAMP)
	$(VENV)/bin/iguana demo

bench: $(STAMP)
	$(VENV)/bin/iguana bench sim

clean:
	rm -rf $(VENV) build install log *.egg-info
