#!/usr/bin/env bash
# The envelope readers (scripts/envelope.sh) against the shipped `nominal` readers on the
# validation words only (issue #113; the rule in docs/protocol.md, "Readers for the envelope"):
# `braille report envelope --validation` reads VAL-WORDS scanned by the validation sensor builds
# (51, 52) with the validation seed, TRIALS scans a row, at `nominal` and `harsh` x 8-200 mm/s x
# 0.6, 1.0, 1.5 mm, speed estimated from the events, each reader behind its own filter (the
# envelope pairs filter as they were trained; the shipped pairs do not), without spelling and
# with the lexicon: the shipped pairs into docs/results/envelope/shipped/ (kept when there), the
# envelope pairs into docs/results/envelope/. No test board or build is read. SIMULATED.
# Then the rule is applied to the two tables: docs/results/envelope/validation.md.
# BRAILLE overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
TRIALS=${TRIALS:-2}
shipped=docs/results/envelope/shipped
envelope=docs/results/envelope
if [[ ! -f "$shipped/validation_envelope.json" ]]; then
  "$b" report envelope --validation --trials "$TRIALS" --models models/nominal --out "$shipped"
fi
"$b" report envelope --validation --trials "$TRIALS" --models models/envelope --out "$envelope"
python3 - "$shipped/validation_envelope.json" "$envelope/validation_envelope.json" "$envelope/validation.md" <<'PY'
import json, sys
shipped, envelope = (json.load(open(p)) for p in sys.argv[1:3])
for t in (shipped, envelope):
    assert (t["board"], t["seed"], t["trials"]) == (shipped["board"], shipped["seed"], shipped["trials"]), "tables of other scans"
def mean(table, arch, realism, speeds):
    v = [c["words_lexicon"][0] for c in table["cells"]
         if c["arch"] == arch and c["realism"] == realism and c["speed_mm_s"] in speeds]
    return sum(v) / len(v)
slow, every = (8, 16, 32, 64), (8, 16, 32, 64, 128, 200)
md = ["# Envelope readers against the shipped readers, validation words (SIMULATED)", "",
      "Made by `bash scripts/envelope_validation.sh`: the rule of docs/protocol.md (\"Readers for the envelope\", "
      "committed before these runs) applied to the shipped pairs' table "
      "([shipped/validation_envelope.md](shipped/validation_envelope.md)) and the envelope pairs' "
      "([validation_envelope.md](validation_envelope.md)): 1 - WER with the lexicon over every printed word of "
      f"{shipped['board']} by builds {shipped['sensor_builds']}, {shipped['trials']} scans a row, speed estimated. "
      "No test board or build was read.", "",
      "| reader | harsh 8-64 mm/s, shipped | envelope | nominal 8-200 mm/s, shipped | envelope | envelope replaces shipped |",
      "| --- | --- | --- | --- | --- | --- |"]
for arch, name in (("snn", "SNN"), ("resnet", "ResNet")):
    hs, he = mean(shipped, arch, "harsh", slow), mean(envelope, arch, "harsh", slow)
    ns, ne = mean(shipped, arch, "nominal", every), mean(envelope, arch, "nominal", every)
    verdict = "yes" if he > hs and ne >= ns - 0.005 else "no"
    md.append(f"| {name} | {hs:.3f} | {he:.3f} | {ns:.3f} | {ne:.3f} | {verdict} |")
open(sys.argv[3], "w").write("\n".join(md) + "\n")
print("\n".join(md))
PY
