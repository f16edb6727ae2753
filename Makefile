# Two set-up commands (see README): `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
QVENV ?= .venv-qgis
PIP = $(VENV)/bin/pip -q --disable-pip-version-check
QPIP = $(QVENV)/bin/pip -q --disable-pip-version-check

.PHONY: demo test test-core test-qgis install qgis-system plugin i18n bench clean

$(VENV)/.installed: pyproject.toml
	test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV)
	$(PIP) install -e ".[test]"
	$(VENV)/bin/lidartrees --compile  # the numba kernels compiled and cached once (~10-30 s)
	touch $@

install: $(VENV)/.installed

demo: $(VENV)/.installed
	$(VENV)/bin/lidartrees demo lidartrees_demo -overwrite

# QGIS 3.22 from Debian (python3-qgis, qgis), installed when missing (needs root, as in CI)
qgis-system:
	@if ! dpkg -s python3-qgis qgis python3-venv qttools5-dev-tools >/dev/null 2>&1; then \
	  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 \
	    install -y -q --no-install-recommends python3-qgis qgis python3-venv qttools5-dev-tools; fi

# Debian's Python with QGIS; numpy < 2 for QGIS's GDAL bindings (and to test numpy 1.24)
$(QVENV)/.installed: pyproject.toml | qgis-system
	test -x $(QVENV)/bin/python || /usr/bin/python3 -m venv --system-site-packages $(QVENV)
	printf 'numpy<1.25\nattrs>=24\n' > $(QVENV)/constraints.txt
	$(QPIP) install -c $(QVENV)/constraints.txt -e ".[test]"
	touch $@

test-core: $(VENV)/.installed
	$(VENV)/bin/python -m pytest -q -p no:cacheprovider --ignore=tests/qgis

test-qgis: $(VENV)/.installed $(QVENV)/.installed
	QT_QPA_PLATFORM=offscreen $(QVENV)/bin/python -m pytest -q -p no:cacheprovider

# the whole suite: numpy 2 (core) and numpy 1.24 inside a real headless QGIS (core + provider)
test: test-core test-qgis

plugin:
	$(PYTHON) scripts/build_plugin.py dist/lidartrees_qgis.zip

# the plugin's translations: provider/i18n/*.ts updated from the texts, *.qm compiled (lrelease)
i18n:
	$(PYTHON) scripts/i18n.py

bench: $(VENV)/.installed
	$(VENV)/bin/python benchmarks/bench_grid.py
	$(VENV)/bin/python benchmarks/bench_trees.py

clean:
	rm -rf $(VENV) $(QVENV) lidartrees_demo dist
