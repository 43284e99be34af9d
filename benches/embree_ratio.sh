#!/usr/bin/env bash
# warpfit's closest-hit rate as a ratio of Embree's, on the same triangles and rays, one
# thread each, measured alternately in one sitting (this is the only comparison docs/performance.md
# makes: absolute rates on a shared machine drift by tens of percent between minutes).
#
#   WARPFIT_DUMP_RAYS=/tmp/rays cargo bench --bench trace -- rays/
#   python3 -m venv /tmp/embree && /tmp/embree/bin/pip install numpy embreex
#   cargo build --release --example ray_rate
#   benches/embree_ratio.sh /tmp/rays/atrium 5
#
# Each round runs Embree (3 passes) with its default triangle test and with its watertight
# one (RTC_SCENE_FLAG_ROBUST, what warpfit's tracer always does), warpfit with the node test
# this CPU picks, and warpfit with the portable node test (5 passes each); the best pass of
# each over all rounds counts. The ratios are printed against both Embree modes.
# Then the batch API: warpfit sorting the rays into a coherent order and walking them in
# packets (`ray_rate CASE 5 packets`, the sort timed with them), against Embree's robust
# mode on the rays in the order given and on the same rays in warpfit's coherent order
# (written once as CASE_coherent.rays.f32 by `ray_rate CASE 1 write-coherent`): the
# binding calls `rtcIntersect1` ray by ray, so the second is Embree's single-ray walk with
# the same coherence.
# To compare two builds in one sitting, copy the other build's ray_rate somewhere and name
# it in BEFORE: it runs in every round too and its ratio is printed beside.
set -euo pipefail
case=$1
rounds=${2:-5}
python=${EMBREE_PYTHON:-/tmp/embree/bin/python}
here=$(cd "$(dirname "$0")/.." && pwd)
rate=$here/target/release/examples/ray_rate
best() { sed -n 's/.*best of [0-9]* passes \([0-9.]*\) Mrays.*/\1/p'; }
before=${BEFORE:-}
e=0 er=0 w=0 p=0 b=0 bp=0 k=0 kp=0 ec=0
"$rate" "$case" 1 write-coherent > /dev/null
ln -sf "$(realpath "$case.tris.f32")" "${case}_coherent.tris.f32"
max() { python3 -c "print(max($1, $2))"; }
for _ in $(seq "$rounds"); do
    e=$(max "$e" "$("$python" "$here/benches/embree_reference.py" "$case" 3 | best)")
    er=$(max "$er" "$("$python" "$here/benches/embree_reference.py" "$case" 3 robust | best)")
    w=$(max "$w" "$("$rate" "$case" 5 | best)")
    p=$(max "$p" "$("$rate" "$case" 5 portable | best)")
    ec=$(max "$ec" "$("$python" "$here/benches/embree_reference.py" "${case}_coherent" 3 robust | best)")
    k=$(max "$k" "$("$rate" "$case" 5 packets | best)")
    kp=$(max "$kp" "$("$rate" "$case" 5 packets portable | best)")
    if [ -n "$before" ]; then
        b=$(max "$b" "$("$before" "$case" 5 | best)")
        bp=$(max "$bp" "$("$before" "$case" 5 portable | best)")
    fi
done
python3 -c "print(f'$case: Embree $e (robust $er), warpfit $w ({$w/$e:.2f}x; {$w/$er:.2f}x robust), portable node test $p ({$p/$e:.2f}x; {$p/$er:.2f}x robust) Mrays/s, best of $rounds rounds')"
python3 -c "print(f'$case, coherent packets: warpfit $k ({$k/$er:.2f}x robust, rays as given; {$k/$ec:.2f}x robust on the coherent order, $ec), portable node test $kp ({$kp/$er:.2f}x; {$kp/$ec:.2f}x) Mrays/s')"
if [ -n "$before" ]; then
    python3 -c "print(f'$case: BEFORE $b ({$b/$e:.2f}x; {$b/$er:.2f}x robust), portable node test $bp ({$bp/$e:.2f}x; {$bp/$er:.2f}x robust) Mrays/s')"
fi
