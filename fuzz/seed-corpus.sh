#!/bin/sh
# Seeds fuzz/corpus/<target>/ from the files in scenes/ (the corpus itself is not committed).
set -eu
cd "$(dirname "$0")"
mkdir -p corpus/obj corpus/scene_toml
for f in ../scenes/*.toml; do cp "$f" corpus/scene_toml/; done
for f in ../scenes/*.obj; do cp "$f" corpus/obj/; done
# An OBJ with its MTL after a NUL byte, as the obj target splits its input.
{ cat ../scenes/cornell_box.obj; printf '\0'; cat ../scenes/cornell_box.mtl; } > corpus/obj/cornell_box+mtl
echo "seeded: $(ls corpus/obj | wc -l) obj, $(ls corpus/scene_toml | wc -l) scene_toml inputs"
