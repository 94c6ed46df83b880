#!/bin/sh
# memory_table.sh: the memory forecast against the measured peak, from 10^4 to 10^7 triangles (FULL=1: to 5x10^7), flat and instanced.
#
# Each scene is generated here (smooth normals: vertices shared, as exported meshes have them) and rendered to a small EXR with --stats: the row is `stat memory`'s
# estimate_bytes, peak_rss_bytes and their ratio, which must stay within 0.75-1.25. Flat scenes are
# bench/big_scene.py's height fields; instanced ones bench/instanced_scene.py's grids of placements of
# one mesh (the same triangle count placed, a thousandth of it stored). FULL=1 adds 5x10^7 flat
# triangles, which needs about 14 GB.
cd "$(dirname "$0")/.." || exit 1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# the first python3 with numpy: a user's pyenv may shadow Debian's
py=python3
python3 -c "import numpy" 2>/dev/null || py=/usr/bin/python3
$py -c "import numpy" 2>/dev/null || { echo "bench memory_table: skipped (python3 numpy missing)"; exit 0; }
bad=0
row() { # kind, triangles, file
    line=$(./pmview "$3" --width 256 --height 256 --iterations 1 --snapshot "$tmp/out.exr" --stats --quiet --max-memory 22G |
           grep '^stat memory')
    estimate=$(echo "$line" | sed -n 's/.*estimate_bytes=\([0-9]*\).*/\1/p')
    peak=$(echo "$line" | sed -n 's/.*peak_rss_bytes=\([0-9]*\).*/\1/p')
    ratio=$(echo "$line" | sed -n 's/.*peak_over_estimate=\([0-9.]*\).*/\1/p')
    printf 'bench memory_table kind=%s triangles=%s file_bytes=%s estimate_mb=%s peak_mb=%s peak_over_estimate=%s\n' \
        "$1" "$2" "$(stat -c %s "$3")" "$((estimate / 1048576))" "$((peak / 1048576))" "$ratio"
    awk -v r="$ratio" 'BEGIN { exit !(r != "" && r >= 0.75 && r <= 1.25) }' || bad=$((bad + 1))
    rm -f "$3"
}
sizes="0.01 0.1 1 10"
[ "${FULL:-0}" = 1 ] && sizes="$sizes 50"
for m in $sizes; do
    tris=$(awk -v m="$m" 'BEGIN { printf "%d", m * 1000000 }')
    $py bench/big_scene.py "$tmp/flat.glb" "$m" --smooth >/dev/null || exit 1
    row flat "$tris" "$tmp/flat.glb"
    if [ -f bench/instanced_scene.py ]; then
        # a thousand placements of one mesh (at least 10 triangles stored)
        per=$((tris / 1000)); [ "$per" -lt 10 ] && per=10
        $py bench/instanced_scene.py "$tmp/inst.glb" --placements 1000 --triangles "$per" >/dev/null || exit 1
        row instanced "$((per * 1000))" "$tmp/inst.glb"
    fi
done
echo "bench memory_table: $bad row(s) outside 0.75-1.25"
[ "$bad" -eq 0 ]
