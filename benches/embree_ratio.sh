#!/usr/bin/env bash
# warpfit's closest-hit rate as a ratio of Embree's, on the same triangles and rays, one
# thread each, measured alternately in one sitting (this is the only comparison the README
# makes: absolute rates on a shared machine drift by tens of percent between minutes).
#
#   WARPFIT_DUMP_RAYS=/tmp/rays cargo bench --bench trace -- rays/
#   python3 -m venv /tmp/embree && /tmp/embree/bin/pip install numpy embreex
#   cargo build --release --example ray_rate
#   benches/embree_ratio.sh /tmp/rays/atrium 5
#
# Each round runs Embree (3 passes), warpfit with the node test this CPU picks, and warpfit
# with the portable node test (5 passes each); the best pass of each over all rounds counts.
set -euo pipefail
case=$1
rounds=${2:-5}
python=${EMBREE_PYTHON:-/tmp/embree/bin/python}
here=$(cd "$(dirname "$0")/.." && pwd)
rate=$here/target/release/examples/ray_rate
best() { sed -n 's/.*best of [0-9]* passes \([0-9.]*\) Mrays.*/\1/p'; }
e=0 w=0 p=0
max() { python3 -c "print(max($1, $2))"; }
for _ in $(seq "$rounds"); do
    e=$(max "$e" "$("$python" "$here/benches/embree_reference.py" "$case" 3 | best)")
    w=$(max "$w" "$("$rate" "$case" 5 | best)")
    p=$(max "$p" "$("$rate" "$case" 5 portable | best)")
done
python3 -c "print(f'$case: Embree $e, warpfit $w ({$w/$e:.2f}x), portable node test $p ({$p/$e:.2f}x) Mrays/s, best of $rounds rounds')"
