#!/usr/bin/env bash
# The scaling table of issue 31 on the lent 16-core machine (the `device` tool), which has
# Python 3.12 with numpy, scipy, numba, pyarrow and matplotlib and reaches no network.
#
# Here, first: download the rest as wheels into the ignored .whl folder,
#   pip download --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
#     --platform manylinux_2_28_x86_64 --platform manylinux2014_x86_64 --platform any -d .whl \
#     dask distributed tornado zict tblib partd locket sqlalchemy alembic mako greenlet \
#     allantools click rich markdown-it-py mdurl pygments pyyaml threadpoolctl cloudpickle \
#     msgpack psutil toolz fsspec sortedcontainers urllib3 jinja2 markupsafe packaging \
#     typing-extensions importlib-metadata zipp setuptools
# then run this with the device tool: command "bash benchmarks/on_16_cores.sh", carry [".whl"],
# timeout about 560 s (the table takes about 6 minutes on 16 cores). $OUT comes back.
set -u
export OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg PYTHONUNBUFFERED=1
SITE=/tmp/site
OUT=${OUT:-.}
t0=$(date +%s)
if ! PYTHONPATH=$SITE python3 -c "import distributed, inertest" 2>/dev/null; then
  python3 -m pip install -q --no-index --no-deps --target $SITE .whl/*.whl 2>&1 | tail -2
fi
PYTHONPATH=$SITE python3 -m pip install -q --no-index --no-deps --no-build-isolation --upgrade \
  --target $SITE . 2>&1 | grep -v WARNING | tail -2
echo "installed in $(( $(date +%s) - t0 )) s"
export PYTHONPATH=$SITE
timeout 420 python3 benchmarks/bench_batch.py 320 500 2>&1 | tee "$OUT/batch.txt"
timeout 150 python3 benchmarks/bench_allan.py 2>&1 | tee "$OUT/allan.txt"
echo "done at $(( $(date +%s) - t0 )) s"
