#!/usr/bin/env bash
# What reading cells costs against reading letters (issue #49's target: within 20%), SIMULATED:
# the very scans of UEB-SENTENCES (16 mm/s, 1.0 mm, test builds and seed, TRIALS scans a row,
# default 1) read by the letters' SNN reader (models/$REALISM/snn-segment + snn-words: its letters
# taken as their Grade-1 cells) and by the cell reader (models/$REALISM/ueb/), one after the
# other, on a quiet machine: seconds of reading (segmentation, classifier, filter) per second of
# stream, and the lexicon's spelling beside. Writes docs/results/$REALISM/ueb/cost.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
realism="${REALISM:-nominal}"
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
out="docs/results/$realism/ueb"; m="models/$realism"
mkdir -p "$out"
common=(eval words --braille ueb-g2 --arch snn --board UEB-SENTENCES --speed 16 --depth 1.0 --trials "${TRIALS:-1}"
  --realism "$realism" --json)
$b "${common[@]}" --segmenter "$m/snn-segment.safetensors" --classifier "$m/snn-words.safetensors" > /tmp/ueb_cost_letters.json
$b "${common[@]}" > /tmp/ueb_cost_cells.json
python3 - "$out" <<'PY'
import json, sys, pathlib
out = pathlib.Path(sys.argv[1])
rows = []
for name, f in [("letters (snn-segment + snn-words)", "/tmp/ueb_cost_letters.json"), ("cells (ueb/snn-segment + snn-cells)", "/tmp/ueb_cost_cells.json")]:
    r = json.loads(pathlib.Path(f).read_text())
    rows.append((name, r["stream_s"], r["read_s"], r["spell_lexicon_s"]))
lines = ["# Reading cost: cells against letters (SIMULATED)", "",
         "Made by `bash scripts/ueb/cost.sh`: the same scans of UEB-SENTENCES at 16 mm/s, 1.0 mm, read by each SNN reader "
         "one after the other. Reading: segmentation, classifier and filter; spelling: the lexicon over every word.", "",
         "| reader | stream s | reading s per s of stream | spelling (lexicon), ms per s of stream | total against the letters' |",
         "| --- | --- | --- | --- | --- |"]
base = (rows[0][2] + rows[0][3]) / rows[0][1]
for name, stream, read, spell in rows:
    total = (read + spell) / stream
    lines.append(f"| {name} | {stream:.1f} | {read / stream:.4f} | {1000 * spell / stream:.4f} | {total / base:.3f}x |")
(out / "cost.md").write_text("\n".join(lines) + "\n")
print("\n".join(lines))
PY
