# Two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export RMW_IMPLEMENTATION ?= rmw_fastrtps_cpp

.PHONY: install test demo bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)

$(STAMP): $(PY) setup.py setup.cfg package.xml
	$(PY) -m pip install -e '.[ros,test]'
	$(VENV)/bin/iguana warm   # compile the kernels and cache the model once, not in four processes at the first run
	touch $(STAMP)

install: $(STAMP)

test: $(STAMP)
	$(PY) -m pytest -q

demo: $(STAMP)
	$(VENV)/bin/iguana demo

bench: $(STAMP)
	$(VENV)/bin/iguana bench sim

clean:
	rm -rf $(VENV) build install log *.egg-info
