#!/bin/sh
# lambert_bench.sh: what specularFactor 0 costs ("bench lambert" lines): a scene whose surfaces say KHR_materials_specular specularFactor 0 against the same scene without the extension rendered by pmview as it was before glTF's dielectric lobe (metallic 0 was Lambert then): the images bit for bit, and the time ratio.
#
# Usage: sh bench/lambert_bench.sh   (BENCH_RUNS alternating runs of each, default 3; BENCH_BEFORE, the
# commit to build the earlier pmview from, default the main line just before the lobe came)
# The earlier pmview is built once from git (git archive) into build/before-lobe/. Each run renders
# scenes/cornell-box.gltf without its two balls (walls and lamp: every surface says specularFactor
# 0) with this pmview, and the same file with every KHR_materials_specular taken out with the
# earlier one, 128x128 on 2
# threads at seed 1 for a fixed number of iterations, in both the path tracer and the default
# (progressive) mode; the two binaries alternate, so a machine's drift falls on both alike. identical=1
# when the EXRs are byte for byte the same; ratio = this pmview's best wall time / the earlier one's.
cd "$(dirname "$0")/.." || exit 1
runs=${BENCH_RUNS:-3}
before=${BENCH_BEFORE:-020b820}
dir=build/before-lobe
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ ! -x "$dir/pmview" ]; then
    if ! git rev-parse --verify -q "$before^{commit}" >/dev/null; then
        echo "bench lambert skipped (commit $before is not in this repository)"; exit 0
    fi
    rm -rf "$dir" && mkdir -p "$dir" && git archive "$before" | tar -x -C "$dir" || { echo "bench lambert: git archive $before failed"; exit 1; }
    make -C "$dir" -j2 pmview >"$tmp/build.log" 2>&1 || { echo "bench lambert: building pmview at $before failed"; tail -n 5 "$tmp/build.log"; exit 1; }
fi
python3 - scenes/cornell-box.gltf "$tmp/lambert.gltf" "$tmp/plain.gltf" <<'EOF' || exit 1
import json, sys
doc = json.load(open(sys.argv[1]))
# the walls and the lamp alone: the mirror ball follows Schlick's Fresnel now, as it should
doc["scenes"][0]["nodes"] = [i for i in doc["scenes"][0]["nodes"] if doc["nodes"][i].get("name") not in ("mirror_ball", "glass_ball")]
json.dump(doc, open(sys.argv[2], "w"))
for m in doc["materials"]:
    m.get("extensions", {}).pop("KHR_materials_specular", None)
    if "extensions" in m and not m["extensions"]:
        del m["extensions"]
doc["extensionsUsed"] = [e for e in doc.get("extensionsUsed", []) if e != "KHR_materials_specular"]
json.dump(doc, open(sys.argv[3], "w"))
EOF
now() { python3 -c "import time; print('%.6f' % time.monotonic())"; }
for mode in pathtrace progressive; do
    iterations=16
    [ "$mode" = pathtrace ] && iterations=64
    best_new=0; best_old=0
    for run in $(seq "$runs"); do
        for which in new old; do
            if [ "$which" = new ]; then bin=./pmview; scene=$tmp/lambert.gltf; else bin=$dir/pmview; scene=$tmp/plain.gltf; fi
            t0=$(now)
            "$bin" "$scene" --mode "$mode" --width 128 --height 128 --iterations $iterations --seed 1 --threads 2 --quiet \
                --snapshot "$tmp/$which.exr" >"$tmp/$which.log" 2>&1 || { echo "bench lambert: $which pmview failed ($mode)"; cat "$tmp/$which.log"; exit 1; }
            t=$(python3 -c "print('%.4f' % ($(now) - $t0))")
            if [ "$which" = new ]; then best_new=$(python3 -c "print(min(x for x in ($best_new, $t) if x > 0))"); else best_old=$(python3 -c "print(min(x for x in ($best_old, $t) if x > 0))"); fi
        done
        cmp -s "$tmp/new.exr" "$tmp/old.exr" && identical=1 || identical=0
    done
    printf 'bench lambert scene=cornell-box-walls mode=%s iterations=%s identical=%s seconds_specular_factor_0=%s seconds_before_lobe=%s ratio=%s runs=%s before=%s\n' \
        "$mode" "$iterations" "$identical" "$best_new" "$best_old" "$(python3 -c "print('%.3f' % ($best_new / $best_old))")" "$runs" "$before"
done
