#!/bin/sh
# Seeds fuzz/corpus/<target>/ from the committed seeds in fuzz/seeds/<target>/ (small files
# made for the purpose, and inputs the fuzzers found crashing) and from the files in scenes/;
# the corpus a run grows is not committed. The shard and first_round seeds are rendered by
# ember itself as well (fresh for today's format; seeds/shard and seeds/first_round hold the same
# renders as committed): build it first (cargo build --release; EMBER overrides the binary).
set -eu
cd "$(dirname "$0")"
EMBER=${EMBER:-../target/release/ember}
mkdir -p corpus/obj corpus/scene_toml corpus/checkpoint corpus/gltf corpus/ply corpus/image corpus/shard corpus/first_round
for t in gltf ply image shard first_round; do cp seeds/$t/* corpus/$t/; done
cp ../tests/data/meshes/*.gltf ../tests/data/meshes/*.glb corpus/gltf/
for f in ../tests/data/meshes/*.ply; do cp "$f" corpus/ply/; done
for f in ../scenes/*.toml; do cp "$f" corpus/scene_toml/; done
for f in ../scenes/*.obj; do cp "$f" corpus/obj/; done
# An OBJ with its MTL after a NUL byte, as the obj target splits its input.
{ cat ../scenes/cornell_box.obj; printf '\0'; cat ../scenes/cornell_box.mtl; } > corpus/obj/cornell_box+mtl

# Checkpoints of the renders the checkpoint target expects (see fuzz_targets/checkpoint.rs):
# a first byte (bit 0: recompute the checksum; bits 1-2: which render), then the file, whose
# checksum is left zero for the target to fill in.
# checkpoint MODE WIDTH HEIGHT SPP PIXEL: PIXEL is printf's text for one pixel's 36 bytes.
checkpoint() {
    settings="width=$2 height=$3 spp=$4 seed=1"
    printf "\\$(printf %03o "$1")"
    printf 'EMBERCK\001'
    printf '\052\0\0\0\0\0\0\0'                          # scene 42
    printf "\\$(printf %03o ${#settings})\\0\\0\\0%s" "$settings"
    printf '\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0'            # no non-finite samples, no time
    printf "\\$(printf %03o "$2")\\0\\0\\0\\$(printf %03o "$3")\\0\\0\\0"
    i=0
    while [ "$i" -lt $(($2 * $3)) ]; do printf "$5"; i=$((i + 1)); done
    printf '\0\0\0\0\0\0\0\0'                            # checksum (recomputed)
}
zero='\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0'
one_white='\001\0\0\0'
for c in 1 2 3 4; do one_white="$one_white\\0\\0\\0\\0\\0\\0\\360\\077"; done  # count 1, sums 1.0
checkpoint 1 3 2 16 "$zero" > corpus/checkpoint/empty-3x2
checkpoint 1 3 2 16 "$one_white" > corpus/checkpoint/white-3x2
checkpoint 3 1 1 1 "$one_white" > corpus/checkpoint/white-1x1
checkpoint 5 2 3 1024 "$one_white" > corpus/checkpoint/white-2x3
checkpoint 0 3 2 16 "$one_white" > corpus/checkpoint/white-3x2-checksum-wrong
# Adaptive checkpoints (the target's mode bit 4): 3x2 pixels at 16 spp, each with its plan's
# 32 bytes: first-round rays and target (u32), sums of squares (3 f64).
adaptive() {
    settings="width=3 height=2 spp=16 seed=1 adaptive=relmse-5x5"
    printf "\\$(printf %03o "$1")"
    printf 'EMBERCK\001\052\0\0\0\0\0\0\0'
    printf "\\$(printf %03o ${#settings})\\0\\0\\0%s" "$settings"
    printf '\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\003\0\0\0\002\0\0\0'
    i=0
    while [ $i -lt 6 ]; do printf "$2"; printf "$3"; i=$((i + 1)); done
    printf '\0\0\0\0\0\0\0\0'
}
plan_zero='\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0'
adaptive 17 "$zero" "$plan_zero" > corpus/checkpoint/adaptive-empty-3x2

# Shard and first-round files of small renders (a whole-image shard, shards of two, with the
# auxiliary sums, and the first rounds of an adaptive render), with the mode byte the targets
# read first (bit 0 set: the checksum is recomputed).
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
scene=../scenes/spheres.toml
render() { "$EMBER" render "$scene" --width 7 --height 5 "$@" 2>/dev/null; }
render --spp 2 --shard 0/1 -o "$tmp/whole.shard"
render --spp 2 --shard 0/2 -o "$tmp/half0.shard"
render --spp 2 --shard 1/2 -o "$tmp/half1.shard"
render --spp 2 --shard 0/1 --aux -o "$tmp/aux.shard"
render --spp 64 --shard 0/1 --first-round -o "$tmp/first.shard"
render --spp 64 --shard 0/2 --first-round -o "$tmp/first0.shard"
seeded() { { printf '\001'; cat "$@"; } ; }
seeded "$tmp/whole.shard" > corpus/shard/whole
seeded "$tmp/aux.shard" > corpus/shard/aux
{ printf '\001'; cat "$tmp/half0.shard"; printf EMBERSPLIT; cat "$tmp/half1.shard"; } > corpus/shard/halves
seeded "$tmp/first.shard" > corpus/shard/first-round
seeded "$tmp/first.shard" > corpus/first_round/first-round
seeded "$tmp/first0.shard" > corpus/first_round/first-round-of-two
for t in obj scene_toml checkpoint gltf ply image shard first_round; do printf '%s ' "$(ls corpus/$t | wc -l) $t"; done
echo "inputs seeded"
