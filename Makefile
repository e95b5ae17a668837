# Two commands do all the set-up on a fresh machine:
#   make demo   - install, then run the main job
#   make test   - install, then run every test
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
DANCE := $(VENV)/bin/dance
STAMP := $(VENV)/.installed
PYPROJECTS := $(wildcard packages/*/pyproject.toml)

.PHONY: install browser blender gltf-tools demo test lint clean

install: $(STAMP) browser blender gltf-tools

$(STAMP): requirements-dev.txt $(PYPROJECTS)
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade "pip>=23.2"
	$(PY) -m pip install --quiet -r requirements-dev.txt
	# madmom 0.16.1 (dance-audio[madmom]) builds only against the installed numpy and Cython
	$(PY) -m pip install --quiet cython==3.3.1 "setuptools==80.10.2"
	$(PY) -m pip install --quiet --no-build-isolation madmom==0.16.1 mido==1.3.3
	$(PY) -m pip check
	touch $(STAMP)

# Chromium for the HTML preview's browser tests (skipped without it): Debian's package, as root
browser:
	@if command -v chromium >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		export DEBIAN_FRONTEND=noninteractive; apt-get update -qq && apt-get install -y -qq chromium >/dev/null; \
	else echo "note: no chromium and not root (or no apt-get): the HTML preview's browser tests will be skipped"; fi

# Blender for the BVH and glb import checks (tests/test_bvh_dcc.py, test_glb.py, skipped without it): Debian's
# packages, as root; its glTF importer needs NumPy in the system Python
blender:
	@if command -v blender >/dev/null 2>&1 && /usr/bin/python3 -c "import numpy" 2>/dev/null; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		export DEBIAN_FRONTEND=noninteractive; apt-get update -qq && apt-get install -y -qq blender python3-numpy >/dev/null; \
	else echo "note: no blender and not root (or no apt-get): Blender's BVH and glb import tests will be skipped"; fi

# The Khronos glTF-Validator and three.js (its GLTFLoader, run in Chromium) for the glb checks
# (tests/test_glb.py, skipped without them): npm packages, pinned, into .tools/node_modules
GLTF_TOOLS := gltf-validator@2.0.0-dev.3.10 three@0.187.0
gltf-tools:
	@if [ -f .tools/node_modules/gltf-validator/package.json ] && [ -f .tools/node_modules/three/package.json ]; then :; \
	elif command -v npm >/dev/null 2>&1; then \
		mkdir -p .tools && npm install --prefix .tools --no-audit --no-fund --silent $(GLTF_TOOLS); \
	else echo "note: no npm: the glb validator and three.js tests will be skipped"; fi

demo: $(STAMP)
	$(DANCE) plugins
	$(DANCE) synth --out out/demo-song --songs 1 --seconds 30 --seed 7
	$(DANCE) compose default --music out/demo-song/synth-0000.wav --out out

test: $(STAMP) browser blender gltf-tools
	$(PY) -m pytest

lint: $(STAMP)
	$(VENV)/bin/ruff check packages tests

clean:
	rm -rf $(VENV) runs out .tools
