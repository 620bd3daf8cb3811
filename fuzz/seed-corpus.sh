#!/bin/sh
# Seeds fuzz/corpus/<target>/ from the files in scenes/ (the corpus itself is not committed).
set -eu
cd "$(dirname "$0")"
mkdir -p corpus/obj corpus/scene_toml corpus/checkpoint
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
echo "seeded: $(ls corpus/obj | wc -l) obj, $(ls corpus/scene_toml | wc -l) scene_toml, $(ls corpus/checkpoint | wc -l) checkpoint inputs"
