# sourced at the start of every device call
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 1
export PYTHONPATH=/tmp/site PYTHONUNBUFFERED=1
python3 -m pip install -q --no-deps --no-build-isolation -e . >/tmp/install.log 2>&1 || { tail -20 /tmp/install.log; exit 1; }
NB="$(dirname "$(command -v python3)")/navbench"; [ -x "$NB" ] || NB="$(python3 -c 'import sysconfig;print(sysconfig.get_path("scripts"))')/navbench"
echo "navbench at $NB"
