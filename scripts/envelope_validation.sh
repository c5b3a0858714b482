#!/usr/bin/env bash
# The envelope readers (scripts/envelope.sh) against the shipped `nominal` readers on the
# validation words only (issue #113; the rule in docs/protocol.md, "Readers for the envelope"):
# VAL-WORDS scanned by the validation sensor builds (51, 52) with the validation seed, TRIALS scans
# a row, at `nominal` and `harsh` x 8-200 mm/s x 0.6, 1.0, 1.5 mm, speed estimated from the events,
# each reader with its own filter (the envelope pairs filter as they were trained; the shipped
# pairs do not), without spelling and with the lexicon. No test board or build is read. SIMULATED.
# Writes docs/results/envelope/validation.{jsonl,md} and applies the rule. JOBS runs reads side
# by side (default 2). BRAILLE overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
TRIALS=${TRIALS:-2}
out=docs/results/envelope/validation
mkdir -p "$(dirname "$out")"
runs=$(mktemp)
for arch in snn resnet; do
  for pair in shipped envelope; do
    for realism in nominal harsh; do
      for speed in 8 16 32 64 128 200; do
        for depth in 0.6 1.0 1.5; do
          echo "$arch $pair $realism $speed $depth" >> "$runs"
        done
      done
    done
  done
done
# one read of a condition scores every spelling: a row per spelling
one() {
  read -r arch pair realism speed depth <<< "$1"
  if [[ $arch == snn ]]; then seg=snn-segment; cls=snn-words; else seg=resnet-tiny-segment; cls=resnet-lite-normaug-words; fi
  if [[ $pair == shipped ]]; then dir=models/nominal; else dir=models/envelope; fi
  "$b" eval words --arch "$arch" --board VAL-WORDS --sensor-builds validation --seed 2000003 --realism "$realism" \
    --segmenter "$dir/$seg.safetensors" --classifier "$dir/$cls.safetensors" \
    --speed "$speed" --depth "$depth" --trials "$TRIALS" --json 2> /dev/null |
    python3 -c "
import json, sys
d = json.load(sys.stdin)
for b in d['by_spell']:
    if b['spell'] in ('none', 'lexicon'):
        print(json.dumps({'arch': '$arch', 'pair': '$pair', 'realism': '$realism', 'speed_mm_s': $speed, 'depth_mm': $depth,
                          'spell': b['spell'], 'trials': $TRIALS, 'word_accuracy': b['word_accuracy'],
                          'wer': b['word_error_rate'], 'cer': b['char_error_rate']}))"
}
export -f one; export b TRIALS
xargs -P "${JOBS:-2}" -I{} bash -c 'one "$@"' _ {} < "$runs" > "$out.jsonl"
rm -f "$runs"
python3 - "$out" "$TRIALS" <<'PY'
import json, sys
out, trials = sys.argv[1], sys.argv[2]
rows = [json.loads(l) for l in open(out + ".jsonl")]
def get(**k):
    return next(r for r in rows if all(r[a] == v for a, v in k.items()))["word_accuracy"]
speeds, depths = (8, 16, 32, 64, 128, 200), (0.6, 1.0, 1.5)
def mean(arch, pair, realism, speeds):
    v = [get(arch=arch, pair=pair, realism=realism, speed_mm_s=s, depth_mm=d, spell="lexicon") for s in speeds for d in depths]
    return sum(v) / len(v)
md = ["# Envelope readers against the shipped readers, validation words (SIMULATED)", "",
      f"Made by `bash scripts/envelope_validation.sh` (TRIALS={trials}): VAL-WORDS scanned by the validation sensor "
      f"builds (51, 52) with the validation seed, {trials} scans a row, speed estimated from the events; 1 - WER over "
      "every printed word, inserted words counted (below zero: more words inserted than printed), without spelling / "
      "with the lexicon. `shipped`: models/nominal/, no filter; `envelope`: models/envelope/ (scripts/envelope.sh), "
      "behind the filter they were trained behind. No test board or build was read. The rule applied below is "
      "docs/protocol.md's \"Readers for the envelope\", committed before these runs.", ""]
md += ["## The rule", "", "| reader | harsh 8-64 mm/s, shipped | envelope | nominal 8-200 mm/s, shipped | envelope | envelope replaces shipped |",
       "| --- | --- | --- | --- | --- | --- |"]
for arch in ("snn", "resnet"):
    hs, he = mean(arch, "shipped", "harsh", speeds[:4]), mean(arch, "envelope", "harsh", speeds[:4])
    ns, ne = mean(arch, "shipped", "nominal", speeds), mean(arch, "envelope", "nominal", speeds)
    verdict = "yes" if he > hs and ne >= ns - 0.005 else "no"
    md.append(f"| {'SNN' if arch == 'snn' else 'ResNet'} | {hs:.3f} | {he:.3f} | {ns:.3f} | {ne:.3f} | {verdict} |")
md += ["", "## Every cell: none / lexicon", "",
       "| reader | pair | preset | depth | " + " | ".join(f"{s} mm/s" for s in speeds) + " |",
       "| --- | --- | --- | --- | " + " | ".join("---" for _ in speeds) + " |"]
for arch in ("snn", "resnet"):
    for realism in ("nominal", "harsh"):
        for d in depths:
            for pair in ("shipped", "envelope"):
                cells = [f"{get(arch=arch, pair=pair, realism=realism, speed_mm_s=s, depth_mm=d, spell='none'):.2f} / "
                         f"{get(arch=arch, pair=pair, realism=realism, speed_mm_s=s, depth_mm=d, spell='lexicon'):.2f}" for s in speeds]
                md.append(f"| {'SNN' if arch == 'snn' else 'ResNet'} | {pair} | {realism} | {d} mm | " + " | ".join(cells) + " |")
open(out + ".md", "w").write("\n".join(md) + "\n")
print("\n".join(md))
PY
