# Sourced by ./run and ./run-tests: make ./.venv hold lamech (editable) and the extras in $1.
# Reinstalls only when pyproject.toml or the extras asked for change.
venv="$here/.venv"
extras="$1"
py="${PYTHON:-python3}"
if [ ! -x "$venv/bin/python" ]; then
    "$py" -m venv "$venv" >&2
fi
stamp="$venv/.lamech-installed"
# the engine's C sources too: an editable install builds them once (setup.py), so a change
# to them must reinstall
want="$(cat "$here/pyproject.toml" "$here/setup.py" "$here"/lamech/numeric/_engine/*.[ch] | cksum) $extras"
if [ ! -f "$stamp" ] || ! grep -qxF -- "$want" "$stamp"; then
    echo "lamech: installing into $venv (first run only) ..." >&2
    # pip's and setuptools' notices go to a log, shown only when the install fails
    log="$venv/install.log"
    if ! { "$venv/bin/python" -m pip install --quiet --upgrade pip \
           && "$venv/bin/python" -m pip install --quiet -e "$here$extras"; } > "$log" 2>&1; then
        tail -n 40 "$log" >&2
        echo "lamech: the install failed (the whole log: $log)" >&2
        exit 1
    fi
    # Byte-compile lamech now: where PYTHONDONTWRITEBYTECODE is set (some shells and CI
    # images set it), every run would otherwise recompile its 80 modules (0.5-0.9 s of CPU).
    "$venv/bin/python" -m compileall -q "$here/lamech" > /dev/null 2>&1 || true
    echo "$want" >> "$stamp"
fi
