#!/usr/bin/env bash
# Builds the `motion` wheel (abi3, CPython >= 3.9) into target/wheels/ and installs it into
# crates/motion-py/.venv, which is created from requirements.txt (pinned) when missing or stale.
set -euo pipefail
cd "$(dirname "$0")/../.."
venv=crates/motion-py/.venv
stamp="$venv/.requirements.sha256"
if [ ! -x "$venv/bin/python" ] || ! sha256sum --status -c "$stamp" 2>/dev/null; then
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
  "$venv/bin/pip" install -q -r crates/motion-py/requirements.txt
  sha256sum crates/motion-py/requirements.txt > "$stamp"
fi
rm -f target/wheels/motion-*.whl
"$venv/bin/maturin" build --release --strip -m crates/motion-py/Cargo.toml -o target/wheels
"$venv/bin/pip" install -q --force-reinstall --no-deps target/wheels/motion-*.whl
echo "installed $(ls target/wheels/motion-*.whl) into $venv"
