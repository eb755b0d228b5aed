#!/usr/bin/env bash
# Every Embree pass on small images, for refactors that must not change them (issue 40):
#   bash scripts/bitcheck.sh OUT_DIR [BASE_DIR]
# renders 22 cases (64x36, 2 frames, seed 7: temple, cafe, park, arcade with an HDR sun map,
# Suzanne from ../shared/assets, street) as .npy into OUT_DIR and, given BASE_DIR (the same
# script's output at an earlier commit, e.g. from a git worktree), says which differ and by how much.
set -u
D=$1; BASE=${2:-}; mkdir -p "$D"
cd "$(dirname "$0")/.."
python3 - "$D/sun.hdr" <<'PY'
import sys
import imagecodecs
import numpy as np
img = np.full((32, 64, 3), 0.3, np.float32)
img[6:9, 20:24] = 400.0
open(sys.argv[1], "wb").write(imagecodecs.rgbe_encode(img))
PY
A=../shared/assets/suzanne/Suzanne.gltf
while read -r name scene pass sets; do
  args=(); for s in $sets; do args+=(--set "$s"); done
  python3 -m app.cli shot "$scene" --pass "$pass" --size 64x36 --frames 2 --seed 7 --set tracer=embree "${args[@]}" \
    --out "$D/$name.png" --raw "$D/$name.npy" > "$D/$name.log" 2>&1 || echo "FAIL $name (see $D/$name.log)"
done <<CASES
t_ao temple ao
t_sh1 temple shadows shadows.lights=one
t_sha temple shadows shadows.lights=all
t_gi temple gi
t_gis temple gi gi.shadows=true
t_refl temple reflections reflections.max_depth=2
t_ref temple reference
t_hyb temple hybrid
t_rtg temple gi gbuffer=rt
c_sha cafe shadows shadows.lights=all
c_sh1 cafe shadows shadows.lights=one
c_gis cafe gi gi.shadows=true
c_ref cafe reference
p_gi park gi
p_ao park ao
a_env arcade gi env=$D/sun.hdr gi.shadows=true
a_envr arcade reference env=$D/sun.hdr
a_envs arcade shadows env=$D/sun.hdr shadows.lights=all
s_gi $A gi env=sky
s_refl $A reflections env=sky
s_ref $A reference env=$D/sun.hdr
st_refl street reflections
CASES
[ -n "$BASE" ] || exit 0
python3 - "$D" "$BASE" <<'PY'
import pathlib
import sys
import numpy as np
new, base = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
cases = sorted(base.glob("*.npy"))
differ = 0
for f in cases:
    a, b = np.load(f), np.load(new / f.name)
    if not np.array_equal(a, b):
        differ += 1
        d = np.abs(a - b)
        print(f"{f.stem}: {int((d > 0).sum())} of {a.size} values differ, at most {d.max():.3g} "
              f"({d.max() / max(a.max(), 1e-30):.2g} of the peak)")
print(f"{len(cases) - differ} of {len(cases)} identical to the bit")
PY
