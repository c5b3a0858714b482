#!/usr/bin/env bash
# What the background-activity filter (`--denoise dv-lab`: DV's noise filter as the seed's lab
# records through it) does for the shipped `nominal` readers, on VALIDATION data only (issue
# #113's design input; no test board or build is read): VAL-WORDS (words no training row or test
# board holds) scanned by the validation sensor builds (51, 52), at `nominal` and `harsh`, 8-64
# mm/s, 1.5 mm, TRIALS scans a row, speed estimated from the events, each architecture, with and
# without the filter, without spelling and with the lexicon. SIMULATED.
# Writes docs/results/denoise_validation.{jsonl,md}. BRAILLE overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
TRIALS=${TRIALS:-2}
out=docs/results/denoise_validation
: > "$out.jsonl"
for arch in snn resnet; do
  if [[ $arch == snn ]]; then seg=snn-segment; cls=snn-words; else seg=resnet-tiny-segment; cls=resnet-lite-normaug-words; fi
  for realism in nominal harsh; do
    for speed in 8 16 32 64; do
      for denoise in none dv-lab; do
        for spell in none lexicon; do
          extra=()
          [[ $denoise != none ]] && extra=(--denoise "$denoise")
          "$b" eval words --arch "$arch" --board VAL-WORDS --sensor-builds validation --realism "$realism" \
            --segmenter "models/nominal/$seg.safetensors" --classifier "models/nominal/$cls.safetensors" \
            --speed "$speed" --trials "$TRIALS" --spell "$spell" --json "${extra[@]}" 2> /dev/null |
            python3 -c "import json,sys; d=json.load(sys.stdin); print(json.dumps({'arch': '$arch', 'realism': '$realism', 'speed_mm_s': $speed, 'denoise': '$denoise', 'spell': '$spell', 'trials': $TRIALS, 'word_accuracy': d['word_accuracy'], 'wer': d['wer'], 'cer': d['cer']}))" >> "$out.jsonl"
        done
      done
    done
  done
done
python3 - "$out" "$TRIALS" <<'PY'
import json, sys
out, trials = sys.argv[1], sys.argv[2]
rows = [json.loads(l) for l in open(out + ".jsonl")]
get = lambda **k: next(r for r in rows if all(r[a] == v for a, v in k.items()))
md = ["# The background-activity filter on the shipped readers, validation words (SIMULATED)", "",
      f"Made by `bash scripts/denoise_validation.sh` (TRIALS={trials}): VAL-WORDS scanned by the validation sensor builds "
      f"(51, 52; no test board or build read), {trials} scans a row, 1.5 mm, speed estimated from the events; the shipped "
      "`nominal` readers, trained without a filter; 1 - WER over every printed word, inserted words counted (below zero: "
      "more words inserted than printed), without spelling / with the lexicon. `dv-lab`: `--denoise dv-lab` (2 ms, 1-8 "
      "neighbours, refractory period 100 us).", "",
      "| reader | preset | filter | 8 mm/s | 16 mm/s | 32 mm/s | 64 mm/s |", "| --- | --- | --- | --- | --- | --- | --- |"]
for arch in ("snn", "resnet"):
    for realism in ("nominal", "harsh"):
        for denoise in ("none", "dv-lab"):
            cells = [f"{get(arch=arch, realism=realism, speed_mm_s=s, denoise=denoise, spell='none')['word_accuracy']:.2f} / "
                     f"{get(arch=arch, realism=realism, speed_mm_s=s, denoise=denoise, spell='lexicon')['word_accuracy']:.2f}"
                     for s in (8, 16, 32, 64)]
            md.append(f"| {'SNN' if arch == 'snn' else 'ResNet'} | {realism} | {denoise} | " + " | ".join(cells) + " |")
open(out + ".md", "w").write("\n".join(md) + "\n")
print("\n".join(md))
PY
