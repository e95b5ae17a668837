# Two commands do all the set-up on a fresh machine:
#   make demo   - install, then run the main job
#   make test   - install, then run every test
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
DANCE := $(VENV)/bin/dance
STAMP := $(VENV)/.installed
PYPROJECTS := $(wildcard packages/*/pyproject.toml)

.PHONY: install demo test lint clean

install: $(STAMP)

$(STAMP): requirements-dev.txt $(PYPROJECTS)
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade "pip>=23.2"
	$(PY) -m pip install --quiet -r requirements-dev.txt
	# madmom 0.16.1 (dance-audio[madmom]) builds only against the installed numpy and Cython
	$(PY) -m pip install --quiet cython==3.3.1 "setuptools==80.10.2"
	$(PY) -m pip install --quiet --no-build-isolation madmom==0.16.1 mido==1.3.3
	$(PY) -m pip check
	touch $(STAMP)

demo: $(STAMP)
	$(DANCE) plugins
	$(DANCE) synth --out out/demo-song --songs 1 --seconds 30 --seed 7
	$(DANCE) compose default --music out/demo-song/synth-0000.wav --out out

test: $(STAMP)
	$(PY) -m pytest

lint: $(STAMP)
	$(VENV)/bin/ruff check packages tests

clean:
	rm -rf $(VENV) runs out
