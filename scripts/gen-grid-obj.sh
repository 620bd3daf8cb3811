#!/bin/sh
# Writes a wavy height-field OBJ of NX x NZ quads (2 * NX * NZ triangles) to stdout.
# Default: 1000 x 500 quads = 1,000,000 triangles, 501,501 vertices (~27 MB).
#   scripts/gen-grid-obj.sh [NX] [NZ] > grid.obj
set -eu
nx=${1:-1000}
nz=${2:-500}
awk -v nx="$nx" -v nz="$nz" 'BEGIN {
    printf "# %d x %d quad height field, %d triangles\n", nx, nz, 2 * nx * nz
    for (j = 0; j <= nz; j++)
        for (i = 0; i <= nx; i++) {
            x = i / nx * 2 - 1; z = (j / nz * 2 - 1) * nz / nx
            printf "v %.6f %.6f %.6f\n", x, 0.05 * sin(20 * x) * cos(30 * z), z
        }
    for (j = 0; j < nz; j++)
        for (i = 0; i < nx; i++) {
            a = j * (nx + 1) + i + 1; b = a + 1; c = a + nx + 1; d = c + 1
            printf "f %d %d %d\nf %d %d %d\n", a, c, b, b, c, d
        }
}'
