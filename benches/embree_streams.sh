#!/usr/bin/env bash
# The tracer against Embree on the rays the tool really traces: each stream a run dumps
# (`WARPFIT_DUMP_STREAMS=DIR warpfit --threads 1 run …`: per stage — probe bake, grid
# bake, fit, evaluation — its first rays, its bounces and its shadow rays, in the order
# issued), one thread each, alternated in one sitting, best pass of all rounds; ratios only.
#
#   python3 -m venv /tmp/embree && /tmp/embree/bin/pip install numpy embreex
#   cargo build --release --example ray_rate
#   WARPFIT_DUMP_STREAMS=/tmp/streams/atrium target/release/warpfit --threads 1 run --scene data/scenes/atrium.toml --out /tmp/fa
#   benches/embree_streams.sh /tmp/streams/atrium 3
#
# Closest-hit streams: Embree's watertight mode (RTC_SCENE_FLAG_ROBUST, the guarantee the
# tracer gives) one ray at a time in the tool's order, against the tracer one ray at a time,
# in packets in the tool's order, and in packets after its coherent sort (the sort timed).
# Shadow streams: occlusion to each ray's own reach, one ray at a time, both. Triangles
# only (a scene's exact spheres are not in the dumped files).
set -euo pipefail
dir=$1
rounds=${2:-3}
python=${EMBREE_PYTHON:-/tmp/embree/bin/python}
here=$(cd "$(dirname "$0")/.." && pwd)
rate=$here/target/release/examples/ray_rate
best() { sed -n 's/.*best of [0-9]* passes \([0-9.]*\) Mrays.*/\1/p'; }
max() { python3 -c "print(max($1, $2))"; }
echo "| stream | rays | Embree robust Mrays/s | tracer, one ray | packets, tool's order | packets, sorted |"
echo "|---|---:|---:|---:|---:|---:|"
while read -r name n; do
    # a stream of a few thousand rays times nothing but the call overhead
    [ "$n" -ge 10000 ] || continue
    case=$dir/$name
    e=0 w=0 k=0 s=0
    for _ in $(seq "$rounds"); do
        if [[ $name == *_shadow ]]; then
            e=$(max "$e" "$("$python" "$here/benches/embree_reference.py" "$case" 3 robust occluded | best)")
            w=$(max "$w" "$("$rate" "$case" 3 occluded | best)")
        else
            e=$(max "$e" "$("$python" "$here/benches/embree_reference.py" "$case" 3 robust | best)")
            w=$(max "$w" "$("$rate" "$case" 3 | best)")
            k=$(max "$k" "$("$rate" "$case" 3 packets nosort | best)")
            s=$(max "$s" "$("$rate" "$case" 3 packets | best)")
        fi
    done
    python3 -c "
e, w, k, s = $e, $w, $k, $s
cell = lambda x: f'{x:.2f} ({x / e:.2f}×)' if x > 0 else '–'
print(f'| $name | $n | {e:.2f} | {cell(w)} | {cell(k)} | {cell(s)} |')"
done < "$dir/streams.txt"
