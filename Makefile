# Two set-up commands (see README): `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
PIP = $(VENV)/bin/pip -q --disable-pip-version-check

.PHONY: demo test install bench clean

$(VENV)/.installed: pyproject.toml
	test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV)
	$(PIP) install -e ".[test]"
	touch $@

install: $(VENV)/.installed

demo: $(VENV)/.installed
	$(VENV)/bin/lidartrees demo lidartrees_demo -overwrite

test: $(VENV)/.installed
	$(VENV)/bin/python -m pytest -q -p no:cacheprovider

bench: $(VENV)/.installed
	$(VENV)/bin/python benchmarks/bench_grid.py

clean:
	rm -rf $(VENV) lidartrees_demo
