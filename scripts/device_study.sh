#!/usr/bin/env bash
# `rtlab study` on the lent GPU machine (the `device` tool; ../shared/GPU.md), in pieces that fit
# its 10-minute calls: bash ../shared/tools/device-pack.sh here, then run there with
# carry=[".device-carry"]:  SCENES="arcade street" bash scripts/device_study.sh
# The study folder is study-device/ in the tree (untracked): a later call carries the scenes
# measured before (study-device/scenes/*.json, put back here from the tar) and the study keeps them.
# Into $OUT: one tar per scene (its kept record and its images shrunk to THUMB px wide, FLIP maps
# included; the full-size images stay there), results.json and the log. REFERENCE_FRAMES and CONFIGS
# (a comma list) pass on to the study.
set -uo pipefail
OUT=${OUT:-out}; DIR=study-device; THUMB=${THUMB:-480}
# the environment an earlier call on this (still warm) machine set up, else set it up now
if [ -f /tmp/rtlab-env.sh ]; then source /tmp/rtlab-env.sh; else source scripts/device_env.sh; fi
python3 -m app.cli devices > "$OUT/devices.txt" 2>&1
timeout "${LIMIT:-480}" python3 -m app.cli study $SCENES --seconds "${SECONDS_PER_CONFIG:-5}" \
    --set "tracer=${TRACER:-cuda}" --reference-frames "${REFERENCE_FRAMES:-4096}" ${CONFIGS:+--configs "$CONFIGS"} \
    --out "$DIR" > "$OUT/study.log" 2>&1
echo "study exit $?" >> "$OUT/study.log"
cp "$DIR/results.json" "$OUT/" 2>/dev/null
python3 - "$DIR" "$THUMB" <<'PY'
import sys
from pathlib import Path
from PIL import Image
folder, width = Path(sys.argv[1]), int(sys.argv[2])
small = folder / "small"
for png in sorted((folder / "images").glob("*.png")):
    im = Image.open(png)
    h = round(im.height * width / im.width)
    (small / "images").mkdir(parents=True, exist_ok=True)
    im.resize((width, h), Image.LANCZOS if "_flip" not in png.name else Image.BOX).save(small / "images" / png.name)
PY
for f in "$DIR"/scenes/*.json; do
  [ -e "$f" ] || continue
  s=$(basename "$f" .json)
  tar -C "$DIR" -cf "$OUT/$s.tar" "scenes/$s.json" -C small $(cd "$DIR/small" && ls images/"${s}"_*.png 2>/dev/null)
done
ls -la "$OUT"
