#!/usr/bin/env bash
# Caustica's vcm (and the others) against SmallVCM's own VCM at equal time, on SmallVCM's Cornell boxes with a
# diffuse floor (scenes/smallvcm-point.toml, scenes/smallvcm-lamp.toml, written by scenes/make_smallvcm_boxes.py).
#
# SmallVCM (Davidovič & Georgiev, MIT licence) is fetched from its public repository at a fixed commit and built
# here, outside the repository. Two edits to its driver, nothing in its integrators: two scene masks appended to
# its list (4: kBothSmallSpheres | kLightPoint, 5: kDefault — its own masks, without kGlossyFloor, whose Phong lobe
# glTF cannot express), and .pfm output (its SavePFM exists; the driver only offered .bmp and .hdr).
#
# Each renderer's error is measured against its own long render of the same scene: its VCM, as many iterations
# as Caustica's reference has samples a pixel, rendered once and kept in $WORK (the two renderers differ in
# Russian roulette and samplers, not in the light transport). relMSE = mean((a−b)²/(b²+0.01)) over pixels and
# channels, as ../shared/peers/metrics.py and `caustica compare`. Needs g++ with OpenMP, a python3 with numpy
# ($PYTHON, default python3) and `cargo build --release` done.
#
# Usage: benches/smallvcm/run.sh [seconds=20] [reference iterations = spp, 150]
# (SMALLVCM_REPO=path clones from a local copy of the repository where github.com is out of reach.)
set -euo pipefail
SECONDS_EACH=${1:-20}
REFERENCE_ITERATIONS=${2:-150}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
WORK=${SMALLVCM_WORK:-/tmp/smallvcm-bench}
CORES=$(nproc)
COMMIT=a13690f03d3414f76ba32b5f0e259e6e5d10ed7b
BIN=${CAUSTICA_BIN:-$ROOT/target/release/caustica}
mkdir -p "$WORK"

if [ ! -x "$WORK/smallvcm" ]; then
  [ -d "$WORK/src" ] || git clone -q "${SMALLVCM_REPO:-https://github.com/SmallVCM/SmallVCM}" "$WORK/src"
  git -C "$WORK/src" checkout -q "$COMMIT"
  python3 - "$WORK/src/src" <<'EOF'
import sys, pathlib
src = pathlib.Path(sys.argv[1])
config = (src / "config.hxx").read_text()
masks = "    Scene::kGlossyFloor | Scene::kBothSmallSpheres  | Scene::kLightBackground\n"
assert masks in config
config = config.replace(masks, masks.rstrip("\n") + ",\n    Scene::kBothSmallSpheres | Scene::kLightPoint,\n"
                        "    Scene::kDefault\n")
config = config.replace('extension != ".bmp" && extension != ".hdr"',
                        'extension != ".bmp" && extension != ".hdr" && extension != ".pfm"')
(src / "config.hxx").write_text(config)
main = (src / "smallvcm.cxx").read_text()
save = '    else if(extension == "hdr")\n'
assert save in main
main = main.replace(save, '    else if(extension == "pfm")\n        fbuffer.SavePFM(config.mOutputName.c_str());\n' + save)
(src / "smallvcm.cxx").write_text(main)
EOF
  g++ -o "$WORK/smallvcm" "$WORK/src/src/smallvcm.cxx" -O3 -march=native -std=c++11 -fopenmp
fi

pfm_relmse() {  # SmallVCM's images: relMSE over pixels and channels, as `caustica compare` prints it
  "${PYTHON:-python3}" - "$1" "$2" <<'EOF'
import sys, numpy as np
def read(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        return np.frombuffer(f.read(), "<f4" if scale < 0 else ">f4").reshape(h, w, 3).astype(np.float64)
a, b = read(sys.argv[1]), read(sys.argv[2])
print(f"{np.mean((a - b) ** 2 / (b * b + 0.01)):.6f}")
EOF
}
exr_relmse() { "$BIN" compare "$1" "$2" | awk '$1 == "relMSE" { print $2 }'; }

for scene in point lamp; do
  id=$([ $scene = point ] && echo 4 || echo 5)
  toml=$ROOT/scenes/smallvcm-$scene.toml
  [ -f "$WORK/ref-smallvcm-$scene.pfm" ] ||
    "$WORK/smallvcm" -s $id -a vcm -i "$REFERENCE_ITERATIONS" -o "$WORK/ref-smallvcm-$scene.pfm" >/dev/null
  [ -f "$WORK/ref-caustica-$scene.exr" ] ||
    "$BIN" render "$toml" --spp "$REFERENCE_ITERATIONS" -o "$WORK/ref-caustica-$scene.exr" >/dev/null
  for a in vcm bpt pt lt ppm; do
    # SmallVCM's -t counts processor time (clock()), all threads together: the cores' share of the wall time.
    cpu=$(/usr/bin/time -f "%e %U %S" -o "$WORK/time" "$WORK/smallvcm" -s $id -a $a -t $((SECONDS_EACH * CORES)) \
      -o "$WORK/smallvcm-$scene-$a.pfm" >/dev/null; awk '{ printf "wall %.1f s, cpu %.1f s", $1, $2 + $3 }' "$WORK/time")
    echo "smallvcm $scene $a $cpu relMSE $(pfm_relmse "$WORK/smallvcm-$scene-$a.pfm" "$WORK/ref-smallvcm-$scene.pfm")"
  done
  for a in vcm bdpt pt lt sppm; do
    cpu=$(/usr/bin/time -f "%e %U %S" -o "$WORK/time" "$BIN" render "$toml" --integrator $a \
      --time-limit "$SECONDS_EACH" -o "$WORK/caustica-$scene-$a.exr" >/dev/null
      awk '{ printf "wall %.1f s, cpu %.1f s", $1, $2 + $3 }' "$WORK/time")
    echo "caustica $scene $a $cpu relMSE $(exr_relmse "$WORK/caustica-$scene-$a.exr" "$WORK/ref-caustica-$scene.exr")"
  done
done
